#!/usr/bin/env python3
"""One line, no traceback, when a script meets bad data.

Importing this module installs a sys.excepthook: an exception a bad or
missing input raises (a text where a number belongs, a missing column or
file, an empty table) ends the script with one line on stderr,
"SCRIPT: bad input: WHAT", and exit 2, like the poolreps command. Ctrl-C
ends it with exit 130 and no traceback. Anything else (a bug) keeps
Python's traceback."""
import csv
import os
import statistics
import sys

DATA_ERRORS = (ValueError, KeyError, IndexError, LookupError, OSError, csv.Error,
               UnicodeDecodeError, ZeroDivisionError, statistics.StatisticsError, StopIteration)


def _hook(kind, value, tb):
    prog = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else "script"
    if issubclass(kind, KeyboardInterrupt):
        sys.exit(130)
    if issubclass(kind, DATA_ERRORS):
        what = str(value) or kind.__name__
        if issubclass(kind, KeyError):
            what = f"no {what} (a missing column or key)"
        print(f"{prog}: bad input: {' '.join(what.split())}", file=sys.stderr)
        sys.exit(2)
    sys.__excepthook__(kind, value, tb)


sys.excepthook = _hook
