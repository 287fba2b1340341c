#!/usr/bin/env python3
"""One line, no traceback, when a script meets bad data.

Importing this module installs a sys.excepthook: an exception a bad or
missing input raises (a text where a number belongs, a missing column or
file, an empty table) ends the script with one line on stderr,
"SCRIPT: FILE:LINE: bad input: WHAT", and exit 2, like the poolreps
command. FILE:LINE is where the CSV row being worked on came from: the rows
of csv.reader and csv.DictReader remember their file and line, and the
innermost call that holds one in a variable names it. Ctrl-C ends the
script with exit 130 and no traceback. Anything else (a bug) keeps
Python's traceback."""
import csv
import os
import statistics
import sys
import traceback

DATA_ERRORS = (ValueError, KeyError, IndexError, LookupError, OSError, csv.Error,
               UnicodeDecodeError, ZeroDivisionError, statistics.StatisticsError, StopIteration)

_READER, _DICT_READER = csv.reader, csv.DictReader


class _Row(list):
    """A csv.reader row and where it came from: (file name or None, line)."""
    __slots__ = ("where",)


class _Record(dict):
    """A csv.DictReader row and where it came from."""
    __slots__ = ("where",)


def _file_name(f):
    name = getattr(f, "name", None)
    return name if isinstance(name, str) else None


class _Reader:
    """csv.reader whose rows are _Rows (DictReader reads through it too)."""

    def __init__(self, f, *args, **kw):
        self._r = _READER(f, *args, **kw)
        self.file = _file_name(f)

    def __iter__(self):
        return self

    def __next__(self):
        row = _Row(next(self._r))
        row.where = (self.file, self._r.line_num)
        return row

    def __getattr__(self, name):  # dialect, line_num
        return getattr(self._r, name)


class _DictReaderAt(_DICT_READER):
    """csv.DictReader whose rows are _Records."""

    def __next__(self):
        row = _Record(super().__next__())
        row.where = (getattr(self.reader, "file", None), self.line_num)
        return row


def _where(tb):
    """FILE:LINE (or "line N") of the row the innermost frame holding one
    worked on, or None."""
    found = None
    for frame, _ in traceback.walk_tb(tb):
        for v in frame.f_locals.values():
            if isinstance(v, (_Row, _Record)):
                found = v.where
    if found is None:
        return None
    name, line = found
    return f"{name}:{line}" if name else f"line {line}"


def _hook(kind, value, tb):
    prog = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else "script"
    if issubclass(kind, KeyboardInterrupt):
        sys.exit(130)
    if issubclass(kind, DATA_ERRORS):
        what = str(value) or kind.__name__
        if issubclass(kind, KeyError):
            what = f"no {what} (a missing column or key)"
        where = _where(tb)
        print(f"{prog}: {where + ': ' if where else ''}bad input: {' '.join(what.split())}",
              file=sys.stderr)
        sys.exit(2)
    sys.__excepthook__(kind, value, tb)


csv.reader = _Reader
csv.DictReader = _DictReaderAt
sys.excepthook = _hook
