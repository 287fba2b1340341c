"""Nothing lost, nothing silent: the guarantees of docs/hardening.md, checked
through the real binary (env POOLREPS, LC_ALL=C) under real conditions.

Every table case runs in its own folder and asserts
  - the exit code;
  - exactly one line on stderr, starting with "poolreps: " (for a success:
    none, or the one remark a command makes);
  - the file system before and after: a snapshot of the whole folder (names,
    types, sizes, content hashes, permission bits, symlink targets) must be
    unchanged, except for the paths a successful case declares it writes.
Further tests send real signals mid-run, fill a small tmpfs, lower
`ulimit -v` and `ulimit -f`, kill a run with SIGKILL, run two runs into one
folder at once, and write as an unprivileged user.
"""
import hashlib
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import pytest

from conftest import ROOT, owner_tag, poolreps_path, run_cmd, wait_for

OK, USAGE, IO, NUM, NOMEM = 0, 1, 2, 3, 4
SAN = os.environ.get("SAN") == "1"

SHOTS = b"x0,y0,x1,y1,vx,vy\n" + b"-0.25,0,0.1,0,0.615,0.03\n" * 5
TRAIN = b"s0,s1,y\n" + b"".join(b"%g,%g,%g\n" % (i * 0.01, (i % 7) * 0.1, (i % 5) * 0.2)
                                for i in range(60))
REPS_IN = b"R,phi0\n" + b"".join(b"%g,%g\n" % (-(i % 7) * 0.1, (i % 3) * 0.3) for i in range(30))
POLICY_TRAIN = b"s0,a0,w\n" + b"".join(b"%g,%g,1\n" % (i * 0.01, (i % 5) * 0.1) for i in range(60))
QUICK = ["--set", "experiment.repetitions=2", "--set", "bench.iterations=3", "-q"]


def binary():
    b = poolreps_path()
    if b is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    return b


def env():
    return dict(os.environ, LC_ALL="C")


def run(args, cwd, stdin=b"", timeout=120, pre=None):
    return run_cmd([binary()] + [str(a) for a in args], cwd=cwd, input=stdin,
                          capture_output=True, env=env(), timeout=timeout, preexec_fn=pre)


def snapshot(root):
    """{relative path: (type, size, sha256, mode bits, symlink target)} of
    everything under root, symlinks not followed."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = os.path.join(dirpath, name)
            st = os.lstat(p)
            rel = os.path.relpath(p, root)
            if stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", 0, "", 0, os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                with open(p, "rb") as f:
                    h = hashlib.sha256(f.read()).hexdigest()
                out[rel] = ("file", st.st_size, h, stat.S_IMODE(st.st_mode), "")
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir", 0, "", stat.S_IMODE(st.st_mode), "")
            else:
                out[rel] = ("other", 0, "", stat.S_IMODE(st.st_mode), "")
    return out


def one_line(r):
    err = r.stderr
    assert err.startswith(b"poolreps: ") and err.endswith(b"\n") and err.count(b"\n") == 1, err
    # escaped: printable UTF-8 only
    text = err.decode("utf-8")
    assert all(c >= " " for c in text[:-1]), err
    return text


def changed(before, after):
    keys = set(before) | set(after)
    return {k for k in keys if before.get(k) != after.get(k)}


# ---- the shared run folders that merge and publish cases start from ----

@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    q = ROOT / "data" / "quadratic.ini"
    for k in (0, 1):
        r = run([q, "-o", base / f"r{k}", "--set", f"experiment.repetition={k}"] + QUICK, base)
        assert r.returncode == 0, r.stderr
    r = run([q, "-o", base / "r1_other", "--set", "experiment.repetition=1",
             "--set", "bench.samples=30"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    r = run([q, "-o", base / "full"] + QUICK, base)
    assert r.returncode == 0, r.stderr
    return base


def copy_runs(*names, edit=None):
    """Setup: copy run folders of the fixture; edit(tmp) afterwards."""
    def f(tmp, runs):
        for n in names:
            shutil.copytree(runs / n, tmp / n, symlinks=True)
        if edit:
            edit(tmp)
    return f


def edit_file(path, fn):
    def f(tmp):
        p = tmp / path
        p.write_bytes(fn(p.read_bytes()))
    return f


def symlink(name, target):
    def f(tmp, runs=None):
        (tmp / name).symlink_to(target)
    return f


def chmod(name, mode):
    def f(tmp, runs=None):
        os.chmod(tmp / name, mode)
    return f


def mkdirs(*names):
    def f(tmp, runs=None):
        for n in names:
            (tmp / n).mkdir(parents=True)
    return f


def both(*fns):
    def f(tmp, runs=None):
        for fn in fns:
            fn(tmp, runs) if fn.__code__.co_argcount == 2 else fn(tmp)
    return f


@dataclass
class Case:
    id: str
    args: list
    code: int
    needles: tuple = ()
    files: dict = field(default_factory=dict)
    setup: Optional[Callable] = None
    stdin: bytes = b""
    writes: tuple = ()             # paths a successful case may create or change
    lines: int = 1                 # stderr lines (0 for a quiet success)


FOREST = ["forest", "--train", "tr.csv", "--test", "tr.csv", "--target", "y", "-q"]
REPS = ["reps", "--return", "R", "--features", "phi0", "-i", "r.csv", "-q"]
POLICY = ["policy", "--train", "p.csv", "--state", "s0", "--action", "a0", "--weight", "w",
          "-i", "p.csv", "-q"]
IN = {"tr.csv": TRAIN, "r.csv": REPS_IN, "p.csv": POLICY_TRAIN, "s.csv": SHOTS,
      "old.csv": b"old,data\n1,2\n"}
RUN_Q = [ROOT / "data" / "quadratic.ini"] + QUICK


def extra_field(b):
    """A raw CSV whose third line has one field too many."""
    lines = b.split(b"\n")
    lines[2] += b",7"
    return b"\n".join(lines)


def rowfix(b):
    """A raw CSV whose third line holds a text where a number belongs."""
    lines = b.split(b"\n")
    f = lines[2].split(b",")
    f[3] = b"abc"
    lines[2] = b",".join(f)
    return b"\n".join(lines)


CASES = [
    # 1. a failed command changes nothing that existed before
    Case("c1_forest_out_full_keeps_leaves", FOREST + ["-o", "/dev/full", "--leaves", "old.csv"], IO,
         ("/dev/full", "No space left on device"), IN),
    Case("c1_forest_out_full_keeps_symlinked_leaves", FOREST + ["-o", "/dev/full", "--leaves", "ln.csv"],
         IO, ("/dev/full",), IN, symlink("ln.csv", "old.csv")),
    Case("c1_forest_leaves_full_keeps_output", FOREST + ["-o", "old.csv", "--leaves", "/dev/full"], IO,
         ("/dev/full",), IN),
    Case("c1_forest_leaves_full_no_new_output", FOREST + ["-o", "new.csv", "--leaves", "/dev/full"], IO,
         ("/dev/full",), IN),
    Case("c1_reps_summary_full_no_output", REPS + ["-o", "w.csv", "--summary", "/dev/full"], IO,
         ("/dev/full",), IN),
    Case("c1_reps_out_full_keeps_summary", REPS + ["-o", "/dev/full", "--summary", "old.csv"], IO,
         ("/dev/full",), IN),
    Case("c1_shoot_trace_full_keeps_output", ["shoot", "-i", "s.csv", "-o", "old.csv", "--trace",
                                             "/dev/full"], IO, ("/dev/full",), IN),
    Case("c1_shoot_out_full_keeps_linked_trace", ["shoot", "-i", "s.csv", "-o", "/dev/full",
                                                 "--trace", "ln.csv"], IO, ("/dev/full",), IN,
         symlink("ln.csv", "old.csv")),
    Case("c1_policy_out_full", POLICY + ["-o", "/dev/full"], IO, ("/dev/full",), IN),
    Case("c1_config_out_full", ["config", "-o", "/dev/full"], IO, ("/dev/full",)),
    Case("c1_shoot_bad_row_keeps_output", ["shoot", "-i", "bad.csv", "-o", "old.csv"], USAGE,
         ("bad.csv:2",), dict(IN, **{"bad.csv": b"x0,y0,x1,y1,vx,vy\n9,9,0,0,1,0\n"})),
    Case("c1_leaves_is_a_folder", FOREST + ["-o", "old.csv", "--leaves", "dir"], IO,
         ("dir", "is a directory"), IN, mkdirs("dir")),
    Case("c1_output_in_missing_folder", ["shoot", "-i", "s.csv", "-o", "no/such/x.csv"], IO,
         ("no/such/x.csv", "No such file"), IN),
    Case("c1_run_publish_blocked_keeps_earlier_run", ["run"] + RUN_Q + ["-o", "full", "--seed", "9"],
         IO, ("full/bench_summary.csv", "is a folder"), {},
         copy_runs("full", edit=lambda t: ((t / "full" / "bench_summary.csv").unlink(),
                                           (t / "full" / "bench_summary.csv").mkdir()))),
    Case("c1_run_bad_key_keeps_folder", ["run"] + RUN_Q + ["-o", "full", "--set", "bench.dims=0"],
         USAGE, ("bench.dims",), {}, copy_runs("full")),
    Case("c1_merge_bad_input_keeps_output_run", ["merge", "-q", "-o", "full", "r0", "r1_other"], USAGE,
         ("bench.samples",), {}, copy_runs("full", "r0", "r1_other")),
    Case("c1_failed_run_removes_the_folders_it_made", ["run"] + RUN_Q + ["-o", "a/b/c", "--set",
                                                                     "experiment.name=rosenbrock",
                                                                     "--set", "bench.dims=1"],
         USAGE, ("bench.dims",)),
    Case("c1_failed_run_keeps_existing_parent", ["run"] + RUN_Q + ["-o", "p/new", "--set",
                                                              "experiment.name=rosenbrock",
                                                              "--set", "bench.dims=1"],
         USAGE, ("bench.dims",), {}, mkdirs("p")),
    Case("c1_run_into_a_file", ["run"] + RUN_Q + ["-o", "old.csv"], IO, ("old.csv",), IN),

    Case("c1_policy_bad_weight_keeps_output", POLICY + ["-o", "old.csv"], USAGE, ("p.csv:2", "'w'"),
         dict(IN, **{"p.csv": b"s0,a0,w\n0.1,0.2,-1\n0.2,0.3,1\n"})),
    Case("c1_config_bad_key_keeps_output", ["config", "--set", "forest.leaves=3", "-o", "old.csv"],
         USAGE, ("forest.leaves", "unknown key"), IN),
    Case("c1_output_is_the_input", ["shoot", "-i", "s.csv", "-o", "s.csv"], OK, (), IN,
         writes=("s.csv",), lines=0),
    Case("c4_unterminated_quote_at_end", ["shoot", "-i", "q.csv"], IO, ("q.csv:2", "unterminated"),
         {"q.csv": b'x0,y0,x1,y1,vx,vy\n1,2,3,4,5,"6\n'}),
    Case("c7_epsilon_twice", REPS + ["--epsilon", "0.5", "--epsilon", "0.7"], USAGE,
         ("--epsilon given twice",), IN),
    Case("c8_very_long_path_one_line", ["shoot", "-i", "d" * 3000 + "/x\n.csv"], IO, ("cannot open",)),

    # 2. merge refuses what it cannot merge faithfully
    Case("c2_merge_different_parameters", ["merge", "-q", "-o", "m", "r0", "r1_other"], USAGE,
         ("r1_other/config.ini", "bench.samples = 30", "r0/config.ini", "50"), {},
         copy_runs("r0", "r1_other")),
    Case("c2_merge_no_final_newline", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv", "no line end"), {},
         copy_runs("r0", "r1", edit=edit_file("r1/bench_curve.csv", lambda b: b[:-1]))),
    Case("c2_merge_header_differs", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv:1", "header differs"), {},
         copy_runs("r0", "r1", edit=edit_file("r1/bench_curve.csv",
                                              lambda b: b.replace(b"samples", b"sample", 1)))),
    Case("c2_merge_field_count", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv:3", "fields"), {},
         copy_runs("r0", "r1", edit=edit_file("r1/bench_curve.csv", extra_field))),
    Case("c2_merge_error_names_source", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv:3", "mean_return"), {},
         copy_runs("r0", "r1", edit=edit_file("r1/bench_curve.csv", rowfix))),
    Case("c2_merge_repetition_twice", ["merge", "-q", "-o", "m", "r1", "r1b"], USAGE,
         ("both hold repetition 1",), {},
         copy_runs("r1", edit=lambda t: shutil.copytree(t / "r1", t / "r1b"))),
    Case("c2_merge_raw_csv_missing", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("bench_curve.csv",), {},
         copy_runs("r0", "r1", edit=lambda t: (t / "r1" / "bench_curve.csv").unlink())),
    Case("c2_merge_missing_repetition", ["merge", "-q", "-o", "m", "r0"], USAGE,
         ("no input ran repetition 1",), {}, copy_runs("r0")),
    Case("c2_merge_two_full_runs", ["merge", "-q", "-o", "m", "full", "r0"], USAGE,
         ("both hold repetition 0",), {}, copy_runs("full", "r0")),
    Case("c2_merge_row_of_another_repetition", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv:2", "repetition 0", "only repetition 1"), {},
         copy_runs("r0", "r1", edit=edit_file("r1/bench_curve.csv",
                                              lambda b: b.replace(b"\n1,", b"\n0,", 1)))),
    Case("c2_merge_fifo_config", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/config.ini", "not a regular file"), {},
         copy_runs("r0", "r1", edit=lambda t: ((t / "r1" / "config.ini").unlink(),
                                               os.mkfifo(t / "r1" / "config.ini")))),
    Case("c2_merge_fifo_raw_csv", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("bench_curve.csv",), {},
         copy_runs("r0", "r1", edit=lambda t: ((t / "r1" / "bench_curve.csv").unlink(),
                                               os.mkfifo(t / "r1" / "bench_curve.csv")))),
    # a run folder's files are never written through links: refused, not read (no hang)
    Case("c6_provenance_is_dev_zero", ["run"] + RUN_Q + ["-o", "full", "--seed", "3"], IO,
         ("full/provenance.txt", "is a symbolic link"), {},
         copy_runs("full", edit=lambda t: ((t / "full" / "provenance.txt").unlink(),
                                           (t / "full" / "provenance.txt").symlink_to("/dev/zero")))),
    Case("c10_names_list_twice", ["config", "--set", "exp3.policies=baseline,baseline"], USAGE,
         ("listed twice",)),
    Case("c2_merge_into_an_input", ["merge", "-q", "-o", "r0", "r0", "r1"], USAGE,
         ("also an input",), {}, copy_runs("r0", "r1")),
    Case("c2_merge_unterminated_quote", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/bench_curve.csv",), {},
         copy_runs("r0", "r1", edit=edit_file("r1/bench_curve.csv", lambda b: b + b'1,"x\n'))),
    Case("c2_merge_missing_config", ["merge", "-q", "-o", "m", "r0", "r1"], IO,
         ("r1/config.ini",), {},
         copy_runs("r0", "r1", edit=lambda t: (t / "r1" / "config.ini").unlink())),

    # 3. exit codes as documented
    Case("c3_tiny_init_std_is_a_parameter_error", ["config", "--set", "bench.init_std=1e-200"], USAGE,
         ("bench.init_std",)),
    Case("c3_infinite_prediction_is_numerical", FOREST[:-1] + ["-q", "--set", "forest.n_min=10", "-o", "p.csv",
                                                            "--leaves", "l.csv"],
         NUM, ("p.csv:2", "non-finite"), {"tr.csv": b"s,y\n0,1.7e308\n0.1,1.7e308\n0.2,1.7e308\n"}),
    Case("c3_event_limit_is_numerical", ["shoot", "-i", "s.csv", "-o", "old.csv", "--trace", "t.csv",
                                         "--set", "sim.max_events=1"], NUM, ("s.csv:2", "sim.max_events"), IN),
    Case("c3_key_combination_is_usage", ["config", "--set", "table.reward_balls=3", "-o", "old.csv"],
         USAGE, ("table.reward_balls",), IN),
    Case("c3_bad_csv_is_io", ["shoot", "-i", "s.csv"], IO, ("s.csv:2",),
         {"s.csv": b"x0,y0,x1,y1,vx,vy\n1,2,3\n"}),

    # 4. bounded reading: the right message at the limit
    Case("c4_config_dev_zero", ["config", "-c", "/dev/zero"], USAGE, ("/dev/zero:1", "NUL")),
    Case("c4_shoot_dev_zero", ["shoot", "-i", "/dev/zero"], IO, ("/dev/zero:1", "NUL")),
    Case("c4_forest_dev_zero", ["forest", "--train", "/dev/zero", "--test", "/dev/zero",
                                "--target", "y"], IO, ("/dev/zero:1",)),
    Case("c4_reps_dev_zero", ["reps", "--return", "R", "-i", "/dev/zero"], IO, ("/dev/zero:1",)),
    Case("c4_policy_dev_zero", ["policy", "--train", "/dev/zero", "--state", "s", "--action", "a",
                                "--weight", "w"], IO, ("/dev/zero:1",)),
    Case("c4_long_field", ["shoot", "-i", "f.csv"], IO, ("f.csv:2", "longer than 4096"),
         {"f.csv": b"x0,y0,x1,y1,vx,vy\n" + b"1" * 5000 + b",0,0,0,0,0\n"}),
    Case("c4_long_parameter_line", ["config", "-c", "p.ini"], USAGE, ("p.ini:2", "longer than"),
         {"p.ini": b"[table]\nfriction = 0.2" + b" " * 6000 + b"\n"}),

    # 7. no option silently ignored
    Case("c7_two_parameter_files", ["config", "-c", "a.ini", "-c", "b.ini"], USAGE, ("-c given twice",),
         {"a.ini": b"[table]\nfriction = 0.3\n", "b.ini": b"[table]\nfriction = 0.4\n"}),
    Case("c7_run_file_and_c", ["run", "a.ini", "-c", "b.ini"], USAGE, ("a.ini", "b.ini"),
         {"a.ini": b"[table]\nfriction = 0.3\n", "b.ini": b"[table]\nfriction = 0.4\n"}),
    Case("c7_forest_input", FOREST + ["-i", "tr.csv"], USAGE, ("-i does not apply",), IN),
    Case("c7_shoot_seed", ["shoot", "-i", "s.csv", "--seed", "3"], USAGE, ("--seed does not apply",), IN),
    Case("c7_merge_parameter_file", ["merge", "-o", "m", "-c", "a.ini", "r0"], USAGE,
         ("-c does not apply",), {"a.ini": b"[table]\nfriction = 0.3\n"}),
    Case("c7_merge_set", ["merge", "-o", "m", "--set", "forest.trees=3", "r0"], USAGE,
         ("--set does not apply",)),
    Case("c7_output_twice", ["shoot", "-i", "s.csv", "-o", "a.csv", "-o", "b.csv"], USAGE,
         ("-o given twice",), IN),
    Case("c7_trace_and_output_on_stdout", ["shoot", "-i", "s.csv", "--trace", "-"], USAGE,
         ("named twice",), IN),
    Case("c7_trace_dev_stdout_and_stdout", ["shoot", "-i", "s.csv", "-o", "/dev/stdout", "--trace", "-"],
         USAGE, ("named twice",), IN),
    Case("c7_trace_same_new_file", ["shoot", "-i", "s.csv", "-o", "x.csv", "--trace", "./x.csv"],
         USAGE, ("named twice",), IN),
    Case("c7_check_past_32_options", ["shoot", "-i", "s.csv"] +
         [a for k in range(40) for a in ("--set", "table.friction=0.2")] + ["--leaves", "x"], USAGE,
         ("--leaves does not apply",), IN),
    Case("c7_shoot_set_key_it_never_reads", ["shoot", "-i", "s.csv", "--set", "forest.trees=3"], USAGE,
         ("--set forest.trees does not apply",), IN),
    Case("c7_reps_seed", REPS + ["--seed", "4"], USAGE, ("--seed does not apply",), IN),
    Case("c7_policy_target_unused", POLICY + ["--target", "a0"], USAGE, ("reward_state",), IN),
    Case("c7_config_writes_its_output", ["config", "--seed", "5", "-o", "c.ini"], OK, (), {},
         writes=("c.ini",), lines=0),

    # 8. every error exactly one line, escaped
    Case("c8_newline_in_path", ["shoot", "-i", "in\nput.csv"], IO, ("in\\x0aput.csv",)),
    Case("c8_escape_in_path", ["shoot", "-i", "a\x1b[31m.csv"], IO, ("a\\x1b[31m.csv",)),
    Case("c8_invalid_utf8_in_path", ["shoot", "-i", os.fsdecode(b"bad\xff.csv")], IO, ("bad\\xff.csv",)),
    Case("c8_valid_utf8_kept", ["shoot", "-i", "caf\u00e9.csv"], IO, ("caf\u00e9.csv",)),
    Case("c8_newline_in_value", ["shoot", "-i", "v.csv"], IO, ("v.csv:3", "\\x0a"),
         {"v.csv": b'x0,y0,x1,y1,vx,vy\n1,2,3,4,5,"a\nb"\n'}),
    Case("c8_escape_in_header", ["shoot", "-i", "h.csv"], IO, ("control character",),
         {"h.csv": b'x0,"y\x1b0",x1,y1,vx,vy\n1,2,3,4,5,6\n'}),
    Case("c8_warning_then_error_one_line", ["reps", "--return", "R", "-i", "c.csv", "-o", "/dev/full"],
         IO, ("/dev/full", "No space left"), {"c.csv": b"R,phi0\n1,2\n1,3\n1,4\n"}),
    Case("c8_write_error_names_file_and_reason", ["shoot", "-i", "s.csv", "-o", "/dev/full"], IO,
         ("/dev/full: write error: No space left on device",), IN),
    Case("c8_bad_set_value_escaped", ["config", "--set", "table.friction=\xe9\x07"], USAGE, ("--set",)),
    Case("c8_no_arguments_one_line", [], USAGE, ("Usage",)),

    # 9. outputs behave like the Unix tools they sit beside
    Case("c9_dev_stdout_on_a_pipe", ["shoot", "-i", "s.csv", "-o", "/dev/stdout"], OK, (), IN, lines=0),
    Case("c9_dev_fd_1_on_a_pipe", ["shoot", "-i", "s.csv", "-o", "/dev/fd/1"], OK, (), IN, lines=0),
    Case("c9_254_byte_name", ["shoot", "-i", "s.csv", "-o", "n" * 254], OK, (), IN,
         writes=("n" * 254,), lines=0),
    Case("c9_255_byte_name", ["shoot", "-i", "s.csv", "-o", "m" * 255], OK, (), IN,
         writes=("m" * 255,), lines=0),
    Case("c9_mode_kept", ["shoot", "-i", "s.csv", "-o", "old.csv"], OK, (), IN,
         chmod("old.csv", 0o640), writes=("old.csv",), lines=0),
    Case("c9_modes_kept_in_a_set", REPS + ["-o", "old.csv", "--summary", "sum.csv"], OK, (),
         dict(IN, **{"sum.csv": b"x\n"}), both(chmod("old.csv", 0o600), chmod("sum.csv", 0o604)),
         writes=("old.csv", "sum.csv"), lines=0),
    Case("c9_symlink_target_written", ["shoot", "-i", "s.csv", "-o", "ln.csv"], OK, (), IN,
         symlink("ln.csv", "old.csv"), writes=("old.csv",), lines=0),
    Case("c9_dangling_symlink_creates_target", ["shoot", "-i", "s.csv", "-o", "ln.csv"], OK, (), IN,
         symlink("ln.csv", "made.csv"), writes=("made.csv",), lines=0),

    # 10. help and validation agree
    Case("c10_eta_min_one_refused", ["config", "--set", "reps.eta_min=1"], USAGE, ("< 1",)),
    Case("c10_window_one_refused", ["config", "--set", "exp3.window=1"], USAGE, (">= 2",)),
    Case("c10_list_key_whole_numbers", ["config", "-c", "l.ini"], USAGE,
         ("l.ini:2", "exp1.trees_list", "whole numbers"), {"l.ini": b"[exp1]\ntrees_list = 1.5\n"}),
    Case("c10_module_check_at_config_time", ["config", "--set", "forest.n_c=0"], USAGE,
         ("forest.n_c",)),
]


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_case(case, tmp_path, runs):
    for name, data in case.files.items():
        (tmp_path / name).write_bytes(data)
    if case.setup:
        if case.setup.__code__.co_argcount == 2:
            case.setup(tmp_path, runs)
        else:
            case.setup(tmp_path)
    before = snapshot(tmp_path)
    r = run(case.args, tmp_path, case.stdin)
    after = snapshot(tmp_path)
    assert r.returncode == case.code, r.stderr
    if case.lines:
        line = one_line(r)
        for n in case.needles:
            assert n in line, (n, line)
    else:
        assert r.stderr == b"", r.stderr
    assert changed(before, after) == set(case.writes), changed(before, after)
    for w in case.writes:
        assert after[w][0] == "file"
        if before.get(w, ("",))[0] == "file":
            assert after[w][3] == before[w][3], "permission bits changed"
    if case.id.startswith("c9_dev"):
        assert r.stdout.startswith(b"x0,y0,x1,y1,pocket0")


def test_help_ranges_agree_with_validation(tmp_path):
    """Every numeric key: the bounds --help-keys documents as allowed pass
    `config`, the ones it documents as excluded are refused."""
    import re
    text = run(["--help-keys"], tmp_path).stdout.decode()
    seen = 0
    for m in re.finditer(r"^  (\S+)\s+= \S+(?: \S+)?  ([\[(])([-0-9.e+]+)\.\.([-0-9.e+]+)([\])])",
                         text, re.M):
        key, lo_br, lo, hi, hi_br = m.groups()
        for value, allowed in ((lo, lo_br == "["), (hi, hi_br == "]")):
            r = run(["config", "--set", f"{key}={value}"], tmp_path)
            if r.returncode == 0 or b"out of range" in r.stderr:
                assert (r.returncode == 0) == allowed, (key, value, r.stderr)
            seen += 1
    assert seen > 100


# ---- bounded memory while reading (class 4) ----

# Runs argv[1:] as a child of this small process and prints the child's peak
# resident size: a child forked straight from pytest would count pytest's own
# pages (its high-water mark survives exec), which grow over a long session.
_PEAK_HELPER = """
import os, subprocess, sys
p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
_, _, ru = os.wait4(p.pid, 0)
print(ru.ru_maxrss)
"""


def peak_kib(args, stdin_gen=None, cwd=None):
    """Run and return (peak RSS in KiB of the child, its stderr)."""
    p = subprocess.Popen([sys.executable, "-c", _PEAK_HELPER, binary()] + [str(a) for a in args],
                         cwd=cwd, env=env(),
                         stdin=subprocess.PIPE if stdin_gen else subprocess.DEVNULL,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)

    def feed():
        try:
            for chunk in stdin_gen():
                p.stdin.write(chunk)
            p.stdin.close()
        except (BrokenPipeError, OSError):
            pass
    t = threading.Thread(target=feed) if stdin_gen else None
    if t:
        t.start()
    out, err = p.communicate() if not stdin_gen else (p.stdout.read(), p.stderr.read())
    p.wait()
    if t:
        t.join(60)
    return int(out), err


def endless_quote():
    yield b"x0,y0,x1,y1,vx,vy\n1,2,3,4,5,\""
    block = b"a" * (1 << 20) + b"\n"
    for _ in range(400):
        yield block


def endless_line():
    """Fields under the field limit, too few for the column limit, on one
    line longer than the line limit."""
    yield b"x0,y0,x1,y1,vx,vy\n"
    block = (b"1" * 4000 + b",") * 256
    for _ in range(400):
        yield block


def many_columns():
    yield b"a" + b",a" * 10
    for _ in range(400):
        yield b",b" * (1 << 19)


@pytest.mark.parametrize("gen,needle", [(endless_quote, b"longer than 4096 bytes"),
                                        (endless_line, b"line longer than"),
                                        (many_columns, b"more than 100000 fields")],
                         ids=["endless_quote", "endless_line", "endless_header"])
@pytest.mark.native
def test_reading_stays_bounded(gen, needle, tmp_path):
    if SAN:
        pytest.skip("AddressSanitizer's shadow memory and quarantine change the resident size")
    peak, err = peak_kib(["shoot", "-i", "-"], gen, cwd=tmp_path)
    assert err.count(b"\n") == 1 and needle in err, err
    assert peak < 64 * 1024, f"peak {peak} KiB"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.native
@pytest.mark.parametrize("args", [["config", "-c", "/dev/zero"], ["shoot", "-i", "/dev/zero"]],
                         ids=["config", "shoot"])
def test_dev_zero_peak_memory(args, tmp_path):
    if SAN:
        pytest.skip("AddressSanitizer's shadow memory and quarantine change the resident size")
    peak, err = peak_kib(args, cwd=tmp_path)
    assert b"NUL" in err and err.count(b"\n") == 1, err
    assert peak < 64 * 1024, f"peak {peak} KiB"


# ---- real conditions: limits, a full file system, signals ----

def limit(resource_name, value):
    import resource

    def pre():
        resource.setrlimit(resource_name, (value, value))
    return pre


def leftovers(root):
    return [p for p in Path(root).rglob("*") if p.name.startswith((".partial-", ".poolreps-tmp-"))]


@pytest.mark.native
@pytest.mark.parametrize("what", ["forest", "policy_fit", "run_exp1"])
def test_ulimit_v_is_out_of_memory(what, tmp_path):
    """More than the address space allows: exit 4, one line, nothing written.
    (`policy --sample N` no longer is such a case: its draws stream, see
    test_ulimit_v_policy_samples_stream; a policy fit still needs its forest
    whole.)"""
    import resource
    if SAN:
        pytest.skip("AddressSanitizer reserves terabytes of address space: ulimit -v cannot apply")
    rows = b"".join(b"%d,0,0.1,0,0.6,0.03\n" % i for i in range(200000))
    (tmp_path / "in.csv").write_bytes(b"x0,y0,x1,y1,vx,vy\n" + rows)
    (tmp_path / "p.csv").write_bytes(POLICY_TRAIN)
    (tmp_path / "old.csv").write_bytes(b"keep\n")
    args = {"forest": ["forest", "--train", "in.csv", "--test", "in.csv", "--target", "vx", "-q", "-o",
                       "old.csv", "--set", "forest.trees=10000", "--set", "forest.n_min=2",
                       "--set", "forest.n_c=1"],
            "policy_fit": ["policy", "--train", "in.csv", "--state", "x0,y0", "--action", "vx,vy", "-i",
                           "in.csv", "-q", "-o", "old.csv", "--set", "policy.trees=10000",
                           "--set", "policy.n_min=2", "--set", "policy.n_c=1"],
            # forests inside an experiment, on worker threads
            "run_exp1": [ROOT / "data" / "exp1.ini", "-q", "-o", "out", "--set", "exp1.subset=100000",
                         "--set", "exp1.train=100000", "--set", "experiment.repetitions=1",
                         "--set", "exp1.trees_list=10000", "--set", "exp1.n_min_list=2",
                         "--set", "experiment.threads=2"]}[what]
    before = snapshot(tmp_path)
    r = run(args, tmp_path, pre=limit(resource.RLIMIT_AS, 300 << 20), timeout=300)
    assert r.returncode == NOMEM, r.stderr
    one_line(r)
    assert snapshot(tmp_path) == before


@pytest.mark.native
def test_ulimit_v_policy_samples_stream(tmp_path):
    """`policy --sample 1000000` under the address-space limit of the cases
    above: it writes the million draws (a state's draws go out 1024 at a
    time), exit 0, the output replaced whole."""
    import resource
    if SAN:
        pytest.skip("AddressSanitizer reserves terabytes of address space: ulimit -v cannot apply")
    (tmp_path / "p.csv").write_bytes(POLICY_TRAIN)
    (tmp_path / "q.csv").write_bytes(b"s0\n0.3\n")
    (tmp_path / "old.csv").write_bytes(b"keep\n")
    args = POLICY[:-3] + ["-i", "q.csv", "-q", "-o", "old.csv", "--sample", "1000000"]
    r = run(args, tmp_path, pre=limit(resource.RLIMIT_AS, 300 << 20), timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stderr == b""
    out = (tmp_path / "old.csv").read_bytes()
    assert out.startswith(b"s0,sample,a0,mean_a0,cov_0_0,status\n0.3,0,")
    assert out.count(b"\n") == 1000001 and out.endswith(b"\n")
    assert out.rsplit(b"\n", 2)[1].startswith(b"0.3,999999,")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.csv", "p.csv", "q.csv"]


@pytest.mark.native
@pytest.mark.parametrize("cmd", ["shoot", "run"])
def test_ulimit_f_sigxfsz(cmd, tmp_path):
    import resource
    (tmp_path / "s.csv").write_bytes(b"x0,y0,x1,y1,vx,vy\n" + b"-0.25,0,0.1,0,0.615,0.03\n" * 200)
    (tmp_path / "old.csv").write_bytes(b"keep\n")
    if cmd == "shoot":
        args = ["shoot", "-i", "s.csv", "-o", "old.csv", "--trace", "t.csv"]
    else:
        args = [ROOT / "data" / "figures.ini", "-q", "-o", "fig"]
    before = snapshot(tmp_path)
    r = run(args, tmp_path, pre=limit(resource.RLIMIT_FSIZE, 8192))
    assert r.returncode == 128 + signal.SIGXFSZ, r.stderr
    one_line(r)
    assert snapshot(tmp_path) == before


@pytest.mark.native
@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a tmpfs needs root")
@pytest.mark.parametrize("what", ["shoot", "run_new", "run_existing", "merge"])
def test_full_tmpfs(what, tmp_path, runs):
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if run_cmd(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)]).returncode:
        pytest.skip("mount -t tmpfs refused (no CAP_SYS_ADMIN)")
    try:
        (tmp_path / "s.csv").write_bytes(b"x0,y0,x1,y1,vx,vy\n" + b"-0.25,0,0.1,0,0.615,0.03\n" * 300)
        if what == "run_existing":
            shutil.copytree(runs / "full", mnt / "fig")
        (mnt / "old.csv").write_bytes(b"keep\n")
        args = {"shoot": ["shoot", "-i", "s.csv", "-o", mnt / "old.csv", "--trace", mnt / "t.csv"],
                "run_new": [ROOT / "data" / "figures.ini", "-q", "-o", mnt / "fig"],
                "run_existing": [ROOT / "data" / "figures.ini", "-q", "-o", mnt / "fig"],
                "merge": ["merge", "-q", "-o", mnt / "m", runs / "r0", runs / "r1"]}[what]
        if what == "merge":
            # leave too little room for the merged run
            (mnt / "fill").write_bytes(b"x" * (60 << 10))
        before = snapshot(mnt)
        r = run(args, tmp_path)
        assert r.returncode == IO, r.stderr
        assert b"No space left on device" in r.stderr
        one_line(r)
        assert snapshot(mnt) == before
    finally:
        run_cmd(["umount", str(mnt)])


def interrupted(argv, ready, sigs, settle, cwd=None):
    """Start argv, wait until ready() (60 s at most) and settle seconds more,
    then send each of sigs (50 ms apart): its exit status and stderr."""
    p = subprocess.Popen(argv, cwd=cwd, env=env(), stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE)
    try:
        assert wait_for(ready, 60), "the run never got ready for the signal"
        time.sleep(settle)
        for i, sig in enumerate(sigs):
            if i:
                time.sleep(0.05)
            p.send_signal(sig)
        _, err = p.communicate(timeout=60)
    finally:
        p.kill()
        p.wait()
    return p.returncode, err


def long_shoot(tmp_path):
    """A shoot that writes a long trace (several seconds)."""
    (tmp_path / "s.csv").write_bytes(b"x0,y0,x1,y1,vx,vy\n" + b"-0.25,0,0.1,0,0.615,0.03\n" * 20000)
    (tmp_path / "old.csv").write_bytes(b"keep\n")
    return ["shoot", "-i", "s.csv", "-o", "old.csv", "--trace", "t.csv", "--set",
            "sim.mode=stepped", "--set", "sim.trace_dt=0.001"]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT,
                                 signal.SIGUSR1, signal.SIGALRM],
                         ids=["INT", "TERM", "HUP", "QUIT", "USR1", "ALRM"])
@pytest.mark.native
def test_signal_mid_shoot(sig, tmp_path):
    args = long_shoot(tmp_path)
    before = snapshot(tmp_path)
    rc, err = interrupted([binary()] + args, lambda: leftovers(tmp_path), [sig], 0.2, tmp_path)
    assert rc == 128 + sig, err
    assert err.count(b"\n") == 1 and b"interrupted by SIG" in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.native
def test_ulimit_t_sigxcpu(tmp_path):
    import resource
    args = long_shoot(tmp_path)
    before = snapshot(tmp_path)
    # soft limit 1 s sends SIGXCPU; the hard limit (SIGKILL) is further off
    r = run(args, tmp_path, pre=lambda: resource.setrlimit(resource.RLIMIT_CPU, (1, 30)), timeout=120)
    assert r.returncode == 128 + signal.SIGXCPU, r.stderr
    assert b"SIGXCPU" in one_line(r).encode()
    assert snapshot(tmp_path) == before


@pytest.mark.native
def test_sigpipe_through_head(tmp_path):
    args = long_shoot(tmp_path)
    args[args.index("-o") + 1] = "-"
    # event mode: the rows (1.6 MB, far beyond a pipe's buffer) come fast,
    # so the write after head has gone is a few ms away, the trace half written
    args[args.index("sim.mode=stepped")] = "sim.mode=event"
    before = snapshot(tmp_path)
    sh = run_cmd(["bash", "-c", 'set -o pipefail; "$@" | head -1 >/dev/null; echo "${PIPESTATUS[0]}" >&2',
                         "sh", binary()] + args, cwd=tmp_path, env=env(), capture_output=True,
                        timeout=120)
    lines = sh.stderr.decode().splitlines()
    assert lines[-1] == str(128 + signal.SIGPIPE), sh.stderr
    assert len(lines) == 2 and "SIGPIPE" in lines[0], sh.stderr
    assert snapshot(tmp_path) == before


def exp3_run(out):
    return [binary(), ROOT / "data" / "exp3.ini", "-q", "-o", out, "--set", "experiment.threads=1"]


@pytest.mark.native
@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGQUIT], ids=["HUP", "QUIT"])
def test_signal_mid_run_removes_staging(sig, tmp_path, runs):
    shutil.copytree(runs / "full", tmp_path / "out")
    before = snapshot(tmp_path)
    rc, err = interrupted(exp3_run(tmp_path / "out"),
                          lambda: any((tmp_path / "out").glob(".partial-*")), [sig], 0.3)
    assert rc == 128 + sig, err
    assert err.count(b"\n") == 1 and b"left as it was" in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.native
def test_signal_mid_run_removes_the_folders_it_made(tmp_path):
    before = snapshot(tmp_path)
    out = tmp_path / "a" / "b" / "out"
    # a second signal: the handler cleans up at once
    rc, err = interrupted(exp3_run(out), lambda: any(out.glob(".partial-*")),
                          [signal.SIGTERM, signal.SIGTERM], 0.3)
    assert rc == 128 + signal.SIGTERM, err
    assert err.count(b"\n") == 1, err
    assert snapshot(tmp_path) == before


@pytest.mark.native
def test_sigkill_leftover_removed_by_next_run(tmp_path):
    out = tmp_path / "out"
    p = subprocess.Popen(exp3_run(out), env=env(), stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    try:
        assert wait_for(lambda: any(out.glob(".partial-*/*.csv")) or any(out.glob(".partial-*")), 60)
        time.sleep(0.3)
    finally:
        p.kill()
        p.wait()
    stale = list(out.glob(".partial-*"))
    assert stale, "SIGKILL left nothing to clean"
    r = run(RUN_Q + ["-o", out], tmp_path)
    assert r.returncode == 0, r.stderr
    assert not list(out.glob(".partial-*"))
    assert sorted(q.name for q in out.iterdir()) == [
        "bench_curve.csv", "bench_summary.csv", "config.ini", "provenance.txt"]


@pytest.mark.native
def test_staging_of_a_live_run_is_left_alone(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    live = out / f".partial-{owner_tag(os.getpid())}"   # this test process is alive
    live.mkdir()
    (live / "x.csv").write_bytes(b"a\n")
    r = run(RUN_Q + ["-o", out], tmp_path)
    assert r.returncode == 0, r.stderr
    assert (live / "x.csv").read_bytes() == b"a\n"


@pytest.mark.native
def test_concurrent_runs_into_one_folder(tmp_path):
    out = tmp_path / "out"
    procs = [subprocess.Popen([binary(), ROOT / "data" / "quadratic.ini", "-o", out,
                               "--seed", str(s), "--set", "experiment.repetitions=2",
                               "--set", "bench.iterations=20", "-q"], env=env(),
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) for s in (1, 2, 3)]
    errs = [p.communicate(timeout=300)[1] for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], errs
    names = sorted(q.name for q in out.iterdir())
    assert names == ["bench_curve.csv", "bench_summary.csv", "config.ini", "provenance.txt"]
    # one complete run: its files agree with its own configuration
    seed = [x for x in (out / "provenance.txt").read_text().splitlines() if x.startswith("seed: ")][0]
    ref = tmp_path / "ref"
    r = run(RUN_Q + ["-o", ref, "--seed", seed.split()[1], "--set", "bench.iterations=20"], tmp_path)
    assert r.returncode == 0
    for n in ("bench_curve.csv", "bench_summary.csv", "config.ini"):
        assert (out / n).read_bytes() == (ref / n).read_bytes(), n


def test_reused_folder_of_another_experiment(tmp_path, runs):
    """A run replaces the files of the earlier run in its folder (as listed
    in its provenance.txt), whatever experiment wrote them, and keeps files
    poolreps did not write."""
    out = tmp_path / "out"
    shutil.copytree(runs / "full", out)
    (out / "fig.png").write_bytes(b"png")
    r = run([ROOT / "data" / "figures.ini", "-q", "-o", out], tmp_path)
    assert r.returncode == 0, r.stderr
    names = {q.name for q in out.iterdir()}
    assert "fig.png" in names and "bench_curve.csv" not in names and "fig7_table.csv" in names
    files = [x for x in (out / "provenance.txt").read_text().splitlines() if x.startswith("files: ")]
    assert set(files[0].split()[1:]) == names - {"fig.png"}


def nobody_dir():
    d = tempfile.mkdtemp(prefix="pr_nobody_")
    os.chmod(d, 0o777)
    return Path(d)


@pytest.mark.native
@pytest.mark.skipif(os.geteuid() != 0, reason="switching to an unprivileged user needs root")
@pytest.mark.parametrize("target", ["file", "summary", "run_folder", "run_file"])
def test_read_only_target_for_a_non_root_user(target):
    if shutil.which("setpriv") is None:
        pytest.skip("setpriv not installed")
    d = nobody_dir()
    try:
        (d / "s.csv").write_bytes(SHOTS)
        (d / "r.csv").write_bytes(REPS_IN)
        (d / "ro.csv").write_bytes(b"read only\n")
        os.chmod(d / "ro.csv", 0o444)
        if target == "run_folder":
            (d / "out").mkdir()
            (d / "out" / "keep.csv").write_bytes(b"k\n")
            os.chmod(d / "out", 0o555)
        if target == "run_file":
            # an earlier run whose summary the user made read-only
            r = run(RUN_Q + ["-o", d / "out"], d)
            assert r.returncode == 0, r.stderr
            os.chmod(d / "out" / "bench_summary.csv", 0o444)
            for p in (d / "out").iterdir():
                os.chown(p, 65534, 65534)
        for p in d.iterdir():
            os.chown(p, 65534, 65534)
        args = {"file": ["shoot", "-i", "s.csv", "-o", "ro.csv"],
                "summary": REPS + ["-o", "new.csv", "--summary", "ro.csv"],
                "run_folder": RUN_Q + ["-o", "out"],
                "run_file": RUN_Q + ["-o", "out", "--seed", "4"]}[target]
        before = snapshot(d)
        r = run_cmd(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
                            binary()] + [str(a) for a in args], cwd=d, env=env(),
                           capture_output=True, timeout=120)
        assert r.returncode == IO, r.stderr
        assert b"Permission denied" in one_line(r).encode()
        assert snapshot(d) == before
    finally:
        shutil.rmtree(d, ignore_errors=True)
