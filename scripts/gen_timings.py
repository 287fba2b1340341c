#!/usr/bin/env python3
"""gen_timings.py — the README's and docs/benchmarks.md's time figures,
generated from committed measurements (docs/data/timing_*.csv), never typed.

  gen_timings.py --record-reproduce OUT   keep OUT/timings.csv and OUT/load.csv
                                          of a full `make reproduce` (refused
                                          for a QUICK=1 run or a busy machine)
  gen_timings.py --record-check LOG       keep the wall time and the slowest
                                          tests of a `make check` log
  gen_timings.py [--check]                write (or compare) the text between
                                          the <!-- timing:NAME --> markers

Each recording is also appended to docs/data/timing_history.csv (commit,
date, command, seconds, machine), so that the text can say how the same two
commands measured on earlier hosts.

A measurement counts as an idle-machine figure only if, while it ran, other
work took less than IDLE_SHARE of the machine's cores (load.csv's
others_share; scripts/reproduce-timed.sh measures it from /proc/stat). The
machine is described from /proc/cpuinfo when a measurement is recorded."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import csv
import datetime
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "docs", "data")
IDLE_SHARE = 0.1
# the whole `make reproduce` after the install step: build, runs, figures,
# report (load.csv's wall_s); 'total' of timings.csv stops before the report
END = "end to end"
FILES = [os.path.join(ROOT, "README.md"), os.path.join(ROOT, "docs", "benchmarks.md")]
HISTORY = os.path.join(DATA, "timing_history.csv")
HISTORY_COLS = ["commit", "date", "what", "seconds", "machine"]


def read_csv(path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"gen_timings.py: {path}: {e.strerror}")


def write_csv(path, rows, cols):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, cols, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, path)


def machine():
    """The machine as /proc/cpuinfo names it, with its widest vector
    instructions (hosts sold under one model name differ in them, and in
    speed)."""
    model, cores, isa = "unknown CPU", os.cpu_count() or 1, ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name") and model == "unknown CPU":
                    model = " ".join(line.split(":", 1)[1].split())
                elif line.startswith("flags") and not isa:
                    flags = line.split(":", 1)[1].split()
                    isa = next((n for f, n in (("avx512f", "AVX-512"), ("avx2", "AVX2"))
                                if f in flags), "no AVX2")
    except OSError:
        pass
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return f"{cores}-core {model}" + (f" with {isa}" if isa else "") + f", {mem:.0f} GiB"


def record_reproduce(out, allow_busy=False):
    if "smoke run" in open(os.path.join(out, "report.html"), encoding="utf-8").read():
        sys.exit(f"gen_timings.py: {out}: a QUICK=1 run, not a full reproduction")
    load = read_csv(os.path.join(out, "load.csv"))[0]
    if float(load["others_share"]) >= IDLE_SHARE and not allow_busy:
        sys.exit(f"gen_timings.py: {out}/load.csv: others_share {load['others_share']} >= "
                 f"{IDLE_SHARE}: the machine was busy, not an idle-machine figure")
    steps = read_csv(os.path.join(out, "timings.csv"))
    if not steps or steps[0]["step"] != "build":
        sys.exit(f"gen_timings.py: {out}/timings.csv: no build row (run `make reproduce`)")
    steps.append({"step": END, "seconds": load["wall_s"]})
    rows = [dict(s, machine=machine(), others_share=load["others_share"]) for s in steps]
    write_csv(os.path.join(DATA, "timing_reproduce.csv"), rows,
              ["step", "seconds", "others_share", "machine"])
    idle = float(load["others_share"]) < IDLE_SHARE
    add_history("make reproduce", load["wall_s"], ("idle " if idle else "busy ") + machine())


def add_history(what, seconds, mach):
    """One row of timing_history.csv for this recording."""
    rows = read_csv(HISTORY) if os.path.exists(HISTORY) else []
    commit = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip() or "unknown"
    rows.append({"commit": commit, "date": datetime.date.today().isoformat(), "what": what,
                 "seconds": seconds, "machine": mach})
    write_csv(HISTORY, rows, HISTORY_COLS)


def record_check(log, busy=False):
    text = open(log, encoding="utf-8", errors="replace").read()
    wall = re.findall(r"^make check: (\d+) s wall$", text, re.M)
    if not wall:
        sys.exit(f"gen_timings.py: {log}: no 'make check: N s wall' line")
    summary = re.findall(r"^=+ (\d+) passed.* in ([\d.]+)s", text, re.M)
    slow = re.findall(r"^([\d.]+)s (call|setup|teardown) +(\S+)$", text, re.M)[:10]
    rows = [{"what": "make check", "seconds": wall[-1],
             "machine": ("busy " if busy else "idle ") + machine()}]
    rows += [{"what": "pytest", "seconds": summary[-1][1], "machine": f"{summary[-1][0]} passed"}]\
        if summary else []
    rows += [{"what": f"{name} ({phase})", "seconds": sec, "machine": ""}
             for sec, phase, name in slow]
    write_csv(os.path.join(DATA, "timing_check.csv"), rows, ["what", "seconds", "machine"])
    add_history("make check", wall[-1], rows[0]["machine"])


def blocks():
    rep = read_csv(os.path.join(DATA, "timing_reproduce.csv"))
    chk = read_csv(os.path.join(DATA, "timing_check.csv"))
    sec = {r["step"]: float(r["seconds"]) for r in rep}
    total = sec[END]
    runs = sum(v for k, v in sec.items() if k.endswith(": run"))
    figs = sum(v for k, v in sec.items() if k.endswith(": figures"))
    mach = rep[0]["machine"]
    busy = float(rep[0]["others_share"])
    idle = "an idle" if busy < IDLE_SHARE else \
        f"a busy (other work took {busy:.0%} of the cores)"
    check = float(chk[0]["seconds"])
    out = {
        "reproduce": f"in {total:.0f} s (measured end to end, build included, on {idle} "
                     f"{mach})",
        "check": f"{check:.0f} s " + ("on the same machine" if chk[0]["machine"].startswith("idle")
                                      else "on a busy machine"),
    }
    lines = [f"`make reproduce` end to end on {idle.split(' (')[0]} {mach} (other work's share of the "
             f"cores measured from /proc/stat: {busy:.0%}): **{total:.1f} s**, "
             f"of which the build {sec['build']:.1f} s and Experiment 4 {sec['exp4: run']:.1f} s. "
             f"Experiment 4 runs in the background from the start, the other runs and the "
             f"figures (one process) beside it, so the steps overlap: their walls sum to "
             f"{runs:.1f} s for the runs and {figs:.1f} s for the figures.",
             "Every step's wall time is in docs/data/timing_reproduce.csv."]
    where = "the same machine" if chk[0]["machine"].startswith("idle") else \
        "the same machine, busy with other work"
    lines += ["", f"`make check` on {where}: **{check:.0f} s** wall"
              + (f" (pytest {chk[1]['machine']} in {float(chk[1]['seconds']):.0f} s on "
                 "2 workers)" if len(chk) > 1 and chk[1]["what"] == "pytest" else "")
              + "; its 10 slowest tests are in docs/data/timing_check.csv."]
    lines += ["", history_sentence()]
    out["table"] = "\n".join(lines)
    return out


def history_sentence():
    """How the two commands measured on every idle recording so far."""
    rows = [r for r in read_csv(HISTORY) if r["machine"].startswith("idle ")]
    parts = []
    for what in ("make reproduce", "make check"):
        sec = [float(r["seconds"]) for r in rows if r["what"] == what]
        if sec:
            parts.append(f"`{what}` {min(sec):.0f}–{max(sec):.0f} s ({len(sec)} recordings)")
    hosts = sorted({r["machine"][len("idle "):] for r in rows})
    return ("Every idle-machine recording so far, at the versions of their day, on "
            f"{len(hosts)} hosts (docs/data/timing_history.csv): " + ", ".join(parts) + ".")


def render(text, b):
    def sub(m):
        name = m.group(1)
        if name not in b:
            sys.exit(f"gen_timings.py: unknown marker timing:{name}")
        body = b[name]
        sep = "\n" if "\n" in body else ""
        return f"<!-- timing:{name} -->{sep}{body}{sep}<!-- /timing -->"
    return re.sub(r"<!-- timing:(\w+) -->.*?<!-- /timing -->", sub, text, flags=re.S)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record-reproduce", metavar="OUT")
    ap.add_argument("--record-check", metavar="LOG")
    ap.add_argument("--allow-busy", action="store_true",
                    help="record a reproduction on a busy machine, saying so in the text")
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    if a.record_reproduce:
        record_reproduce(a.record_reproduce, a.allow_busy)
    if a.record_check:
        record_check(a.record_check, a.allow_busy)
    b = blocks()
    bad = []
    for path in FILES:
        old = open(path, encoding="utf-8").read()
        new = render(old, b)
        if a.check:
            if new != old:
                bad.append(os.path.relpath(path, ROOT))
        elif new != old:
            with open(path + ".tmp", "w", encoding="utf-8") as f:
                f.write(new)
            os.replace(path + ".tmp", path)
    if bad:
        sys.exit(f"gen_timings.py: {', '.join(bad)}: time figures differ from docs/data/"
                 "timing_*.csv (run scripts/gen_timings.py)")


if __name__ == "__main__":
    main()
