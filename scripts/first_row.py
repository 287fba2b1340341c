#!/usr/bin/env python3
"""first_row.py CMD [ARG]... — run CMD with its standard output on a pipe,
read and discard everything, and print the seconds from the start until
the first row after the header arrived (CMD's exit code is passed on)."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import subprocess
import sys
import time


def main():
    t0 = time.monotonic()
    p = subprocess.Popen(sys.argv[1:], stdout=subprocess.PIPE)
    lines, first = 0, float("nan")
    while True:
        b = os.read(p.stdout.fileno(), 1 << 20)
        if not b:
            break
        if lines < 2:
            lines += b.count(b"\n")
            if lines >= 2:
                first = time.monotonic() - t0
    print("%.3f" % first)
    return p.wait()


if __name__ == "__main__":
    sys.exit(main())
