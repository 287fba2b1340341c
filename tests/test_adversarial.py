"""More of the guarantees of docs/hardening.md, as a hostile new user would
try them: table-driven cases through the real binary, each asserting the
exit code, exactly one stderr line and the file system before and after
(the case table and helpers of tests/test_safety.py), plus signals sent to
`collect` and `sweep` folders written with awkward names.
"""
import os
import shutil
import signal
import subprocess
import time

import pytest

from conftest import ROOT
from test_safety import (IN, IO, OK, QUICK, RUN_Q, USAGE, Case, binary, chmod, copy_runs, edit_file,
                         env, leftovers, one_line, run, runs, snapshot, wait_for)
from test_safety import test_case as _check_case

assert runs  # the module fixture of test_safety: the run folders merge cases start from
QUAD = ROOT / "data" / "quadratic.ini"
SWEEP_Q = ["--set", "experiment.repetitions=2", "--set", "bench.iterations=3", "-q"]


def lines_of(path, fn):
    """Edit a file line by line: fn(list of lines) -> list of lines."""
    return edit_file(path, lambda b: b"\n".join(fn(b.split(b"\n")[:-1])) + b"\n")


def header_only(lines):
    return lines[:1]


def drop_last(lines):
    return lines[:-1]


def drop_third(lines):
    return lines[:2] + lines[3:]


def repeat_second(lines):
    return lines[:2] + lines[1:]


def only_repetition_0(lines):
    return [x for x in lines if not x.startswith(b"1,")]


RUN_FILES = ("bench_curve.csv", "bench_summary.csv", "config.ini", "provenance.txt")

CASES = [
    # 2. merge refuses what it cannot merge faithfully: every repetition must
    # have as many rows as the others (a row lost or repeated), and every
    # input must be a finished run (provenance.txt, published last)
    Case("c2_merge_row_repeated", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv", "4 rows of repetition 1", "3 of repetition 0"), {},
         copy_runs("r0", "r1", edit=lines_of("r1/bench_curve.csv", repeat_second))),
    Case("c2_merge_last_row_lost", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv", "2 rows of repetition 1"), {},
         copy_runs("r0", "r1", edit=lines_of("r1/bench_curve.csv", drop_last))),
    Case("c2_merge_middle_row_lost", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("bench_curve.csv", "lost or repeated"), {},
         copy_runs("r0", "r1", edit=lines_of("r0/bench_curve.csv", drop_third))),
    Case("c2_merge_rows_of_one_input_lost", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv", "no rows of repetition 1"), {},
         copy_runs("r0", "r1", edit=lines_of("r1/bench_curve.csv", header_only))),
    Case("c2_merge_first_input_header_only", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r0/bench_curve.csv", "no rows of repetition 0"), {},
         copy_runs("r0", "r1", edit=lines_of("r0/bench_curve.csv", header_only))),
    Case("c2_merge_full_run_missing_a_repetition", ["merge", "-q", "-o", "m", "full"], IO,
         ("full/bench_curve.csv", "no rows of repetition 1"), {},
         copy_runs("full", edit=lines_of("full/bench_curve.csv", only_repetition_0))),
    Case("c2_merge_into_existing_keeps_it_on_lost_row", ["merge", "-q", "-o", "full", "r0", "r1"],
         IO, ("r1/bench_curve.csv",), {},
         copy_runs("full", "r0", "r1", edit=lines_of("r1/bench_curve.csv", drop_last))),
    Case("c2_merge_no_provenance", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/provenance.txt", "not a finished run"), {},
         copy_runs("r0", "r1", edit=lambda t: (t / "r1" / "provenance.txt").unlink())),
    Case("c2_merge_provenance_is_a_folder", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/provenance.txt", "not a regular file"), {},
         copy_runs("r0", "r1", edit=lambda t: ((t / "r1" / "provenance.txt").unlink(),
                                               (t / "r1" / "provenance.txt").mkdir()))),

    # 7. no option silently ignored: sweep --missing only reads its folder
    Case("c7_sweep_missing_with_output", ["sweep", "--missing", "s", "-o", "x"], USAGE,
         ("--missing takes no other option", "-o")),
    Case("c7_sweep_missing_with_set", ["sweep", "--missing", "s", "--set", "bench.samples=3"], USAGE,
         ("--missing", "--set")),
    Case("c7_sweep_missing_with_grid", ["sweep", "--missing", "s", "--grid", "bench.samples=3,4"],
         USAGE, ("--missing", "--grid")),
    Case("c7_sweep_missing_with_seed", ["sweep", "--missing", "s", "--seed", "3"], USAGE,
         ("--missing", "--seed")),
    Case("c7_sweep_missing_with_split", ["sweep", "--missing", "s", "--split", "variant"], USAGE,
         ("--missing", "--split")),

    # 10. a list key refuses a value listed twice (a sweep's variants would
    # share one output folder; a summary would hold one setting twice)
    Case("c10_list_value_twice_set", ["config", "--set", "exp1.trees_list=10,10"], USAGE,
         ("exp1.trees_list", "10 listed twice")),
    Case("c10_list_value_twice_file", ["config", "-c", "l.ini", "-o", "old.csv"], USAGE,
         ("l.ini:2", "exp2.sizes", "20 listed twice"), dict(IN, **{"l.ini": b"[exp2]\nsizes = 20, 50,20\n"})),
    Case("c10_list_big_value_twice", ["config", "--set", "exp2.sizes=10000000,10000000"], USAGE,
         ("10000000 listed twice",)),

    # 9. a run folder's files keep their permission bits (and owner, for root)
    Case("c9_run_keeps_modes", ["run"] + RUN_Q + ["-o", "full", "--seed", "5"], OK, (), {},
         None, writes=tuple("full/" + f for f in RUN_FILES), lines=0),
    Case("c9_merge_keeps_modes", ["merge", "-q", "-o", "full", "r0", "r1"], OK, (), {},
         None, writes=("full/provenance.txt",), lines=0),

    # sweep: a path jobs.txt cannot hold on one line is refused, nothing made
    Case("c1_sweep_folder_with_line_break", ["sweep", QUAD, "--grid", "bench.samples=30,40", "-o",
                                             "a\nb"] + SWEEP_Q, USAGE, ("a\\x0ab", "line break")),
]


def _modes(tmp, runs):
    shutil.copytree(runs / "full", tmp / "full", symlinks=True)
    for name, mode in (("bench_curve.csv", 0o600), ("config.ini", 0o640), ("provenance.txt", 0o444)):
        os.chmod(tmp / "full" / name, mode)


def _merge_modes(tmp, runs):
    _modes(tmp, runs)
    for n in ("r0", "r1"):
        shutil.copytree(runs / n, tmp / n, symlinks=True)


CASES[[c.id for c in CASES].index("c9_run_keeps_modes")].setup = _modes
CASES[[c.id for c in CASES].index("c9_merge_keeps_modes")].setup = _merge_modes


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_adversarial_case(case, tmp_path, runs):
    _check_case(case, tmp_path, runs)


def test_slurm_log_path_keeps_a_percent_sign(tmp_path):
    """'%' in the sweep folder's name is literal for Slurm's --output."""
    r = run(["sweep", QUAD, "--grid", "bench.samples=30", "-o", "p%j"] + SWEEP_Q, tmp_path)
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "p%j" / "slurm.sbatch").read_text()
    assert f"--output={tmp_path}/p%%j/logs/%A_%a.out" in text, text
