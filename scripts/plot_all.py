#!/usr/bin/env python3
"""plot_all.py [--stdin] [--timings FILE] [DIR...] — draw the figures of
poolreps output folders in ONE Python process: matplotlib is imported once,
then each folder goes to the plot script of its experiment (experiment.name
in DIR/config.ini), by its kind in the registry (scripts/experiments.py):
figures -> plot_sim_figures, an experiment NAME -> plot_NAME, a benchmark ->
plot_benchmarks. scripts/plot is its
launcher. --stdin also reads folder names, one a line, as they come (so
`make reproduce` draws a folder while the next experiment runs); --timings
appends 'NAME: figures,SECONDS' per folder to FILE. The first folder that
fails stops the run with its script's message and exit status."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import argparse
import configparser
import importlib
import os
import sys
import time

import figstyle  # noqa: F401  (first: it picks a Python with matplotlib)
import experiments

HERE = os.path.dirname(os.path.abspath(__file__))
KIND_SCRIPTS = {"figures": "plot_sim_figures", "benchmark": "plot_benchmarks"}


def scripts():
    """{experiment name: the module that draws its folder}."""
    return {r["name"]: KIND_SCRIPTS.get(r["kind"], "plot_" + r["name"])
            for r in experiments.registry()}


def experiment_name(d):
    """experiment.name of d/config.ini, or None."""
    cp = configparser.ConfigParser(interpolation=None, strict=False,
                                   inline_comment_prefixes=(";", "#"))
    try:
        with open(os.path.join(d, "config.ini"), encoding="utf-8") as f:
            cp.read_file(f)
        return cp.get("experiment", "name", fallback=None)
    except (OSError, UnicodeDecodeError, configparser.Error):
        return None


def plot(d, timings=None, known=None):
    """Draw folder d's figures with its experiment's script (known: scripts())."""
    known = known or scripts()
    name = experiment_name(d)
    if name not in known:
        sys.exit(f"plot: {d}/config.ini: no experiment.name this script knows "
                 "(not a poolreps output folder?)")
    script = known[name]
    module = importlib.import_module(script)
    t0 = time.monotonic()
    argv0, sys.argv[0] = sys.argv[0], os.path.join(HERE, script + ".py")
    try:
        module.main([d])
    finally:
        sys.argv[0] = argv0
        sys.stdout.flush()
    if timings:
        with open(timings, "a", encoding="utf-8") as f:
            f.write(f"{name}: figures,{time.monotonic() - t0:.2f}\n")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="plot", description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="*", metavar="DIR")
    ap.add_argument("--stdin", action="store_true", help="also read folders from stdin")
    ap.add_argument("--timings", help="append per-folder wall seconds to this CSV")
    a = ap.parse_args(argv)
    if not a.dirs and not a.stdin:
        sys.exit("usage: plot DIR...")
    known = scripts()
    for d in a.dirs:
        plot(d, a.timings, known)
    if a.stdin:
        for line in sys.stdin:
            if line.strip():
                plot(line.rstrip("\n"), a.timings, known)


if __name__ == "__main__":
    main()
