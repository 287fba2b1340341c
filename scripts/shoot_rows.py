#!/usr/bin/env python3
"""shoot_rows.py N [SEED] — N valid `poolreps shoot` input rows on stdout:
4 balls (cue, reward ball, two obstacles, each in its own band of the
default table, so no two overlap and none is off the table or in a pocket)
and an action of speed below 1.5 m/s. 4096 distinct seeded rows repeat
(cheap to write 10 M of them); the bytes depend only on N and SEED."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import random
import sys

BANDS = ((-0.45, -0.30), (0.05, 0.20), (-0.20, -0.05), (0.25, 0.45))


def block(seed, rows=4096):
    rng = random.Random(seed)
    lines = []
    for _ in range(rows):
        f = []
        for lo, hi in BANDS:
            f.append("%.3f" % rng.uniform(lo, hi))
            f.append("%.3f" % rng.uniform(-0.2, 0.2))
        f.append("%.2f" % rng.uniform(0.1, 1.0))
        f.append("%.2f" % rng.uniform(-0.5, 0.5))
        lines.append(",".join(f) + "\n")
    return lines


def main():
    n = int(sys.argv[1])
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    out = sys.stdout
    out.write("x0,y0,x1,y1,x2,y2,x3,y3,vx,vy\n")
    lines = block(seed)
    whole = "".join(lines)
    for _ in range(n // len(lines)):
        out.write(whole)
    out.write("".join(lines[:n % len(lines)]))


if __name__ == "__main__":
    main()
