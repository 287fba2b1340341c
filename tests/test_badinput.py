"""Bad-input suite: malformed parameter files, CSVs and command lines.

Every case runs the real binary (env POOLREPS, LC_ALL=C) in its own temporary
folder and checks the contract of docs/hardening.md:
  - exactly one line on stderr, starting with "poolreps: ", naming the file
    and, where they apply, the line and the key or column;
  - the documented exit code: 1 bad usage or parameter, 2 I/O or malformed
    CSV, 3 numerical failure, 4 out of memory;
  - nothing written: the -o path does not exist afterwards, and no
    ".poolreps-tmp-*" or ".partial-*" is left anywhere.
Valid-but-odd inputs (CRLF, BOM, quoted fields, blanks, comments) must work
and give the same result as their plain spelling.
"""
import os
import re
import random
from dataclasses import dataclass
from typing import Callable, Optional

import pytest

USAGE, IO, NUM, NOMEM = 1, 2, 3, 4

GOOD_INI = b"[experiment]\nname = exp1\nseed = 3\n\n[table]\nfriction = 0.25\n"
SHOT_HEADER = b"x0,y0,x1,y1,vx,vy\n"
GOOD_ROW = b"-0.25,0,0.25,0,0.5,0\n"
GOOD_CSV = SHOT_HEADER + GOOD_ROW + b"-0.25,0,0.25,0.1,0.4,0.1\n"
# REPS input: returns R, features phi0..phi2, base weights q
REPS_CSV = b"R,phi0,phi1,phi2,q\n" + b"".join(
    b"%g,%g,%g,%g,1\n" % (-(i % 7) * 0.1, 1, (i % 5) * 0.2, (i % 3) * 0.3) for i in range(40))
# forest / policy training data: inputs s0,s1, targets a0,a1, weight w
TRAIN_CSV = b"s0,s1,a0,a1,w\n" + b"".join(
    b"%g,%g,%g,%g,%g\n" % (i * 0.01, (i % 9) * 0.1, i * 0.02, -(i % 4) * 0.1, 1 + i % 3)
    for i in range(60))
STATES_CSV = b"s0,s1\n0.1,0.2\n0.3,0.4\n"


def junk(seed, n):
    """Reproducible binary junk."""
    return bytes(random.Random(seed).getrandbits(8) for _ in range(n))


def ini(*lines):
    return ("\n".join(lines) + "\n").encode()


def shots(*rows):
    return SHOT_HEADER + b"".join(r.encode() + b"\n" for r in rows)


RUN = ["run", "p.ini", "-o", "outdir", "-q"]
SHOOT = ["shoot", "-i", "in.csv", "-o", "out.csv", "-q"]
SHOOT_C = ["shoot", "-c", "p.ini", "-i", "in.csv", "-o", "out.csv", "-q"]
REPS = ["reps", "--return", "R", "--features", "phi*", "-i", "r.csv", "-o", "out.csv", "-q"]
FOREST = ["forest", "--train", "train.csv", "--test", "test.csv", "--target", "a0,a1",
          "-o", "out.csv", "-q"]
POLICY = ["policy", "--train", "train.csv", "--state", "s0,s1", "--action", "a0,a1",
          "--weight", "w", "-i", "states.csv", "-o", "out.csv", "-q"]


@dataclass
class Case:
    id: str
    args: list
    code: int
    needles: tuple = ()             # substrings the error line must contain
    files: Optional[dict] = None    # name -> bytes, written before the run
    setup: Optional[Callable] = None  # f(tmp_path) after the files are written
    stdin: Optional[bytes] = None
    root_ok: bool = True            # False: meaningless as root (root reads anything)


def chmod000(name):
    def f(tmp):
        os.chmod(tmp / name, 0)
    return f


def mkdir(name):
    def f(tmp):
        (tmp / name).mkdir()
    return f


P = "p.ini"
CASES = [
    # ---- parameter files -------------------------------------------------
    Case("ini_missing", ["run", "nope.ini", "-o", "outdir"], IO, ("nope.ini", "cannot open")),
    Case("ini_parent_not_a_folder", ["run", "afile/p.ini", "-o", "outdir"], IO, ("afile/p.ini",),
         files={"afile": b"x"}),
    Case("ini_unreadable", RUN, IO, (P, "ermission denied"), files={P: GOOD_INI},
         setup=chmod000(P), root_ok=False),
    Case("ini_is_a_folder", RUN, IO, (P, "directory"), setup=mkdir(P)),
    Case("ini_empty", RUN, USAGE, (P, "empty"), files={P: b""}),
    Case("ini_only_comments", RUN, USAGE, (P,), files={P: b"; nothing here\n# nor here\n\n"}),
    Case("ini_section_without_keys", SHOOT_C, USAGE, (P,), files={P: b"[table]\n", "in.csv": GOOD_CSV}),
    Case("ini_binary_junk", RUN, USAGE, (P + ":",), files={P: junk(1, 4000)}),
    Case("ini_png_image", RUN, USAGE, (P + ":1:",),
         files={P: b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0\0\x10\0\0\0\x10\x08\x06\0\0\0"}),
    Case("ini_nul_byte", RUN, USAGE, (P + ":2:",), files={P: b"[table]\nfriction = 0.2\0\n"}),
    Case("ini_control_character", RUN, USAGE, (P + ":2:",),
         files={P: b"[table]\nfriction = 0.2\x1b[2J\n"}),
    Case("ini_truncated_value", RUN, USAGE, (P + ":3:", "table.restitution"),
         files={P: b"[table]\nfriction = 0.2\nrestitution ="}),
    Case("ini_truncated_section", RUN, USAGE, (P + ":3:",),
         files={P: b"[table]\nfriction = 0.2\n[si"}),
    Case("ini_nan", RUN, USAGE, (P + ":2:", "table.friction"), files={P: ini("[table]", "friction = nan")}),
    Case("ini_inf", RUN, USAGE, (P + ":3:", "table.restitution"),
         files={P: ini("[table]", "friction = 0.3", "restitution = inf")}),
    Case("ini_minus_inf", RUN, USAGE, (P + ":2:", "reward.miss_penalty"),
         files={P: ini("[reward]", "miss_penalty = -inf")}),
    Case("ini_number_too_large", RUN, USAGE, (P + ":2:", "table.friction"),
         files={P: ini("[table]", "friction = 1e999")}),
    Case("ini_number_too_small", RUN, USAGE, (P + ":2:", "table.ball_radius"),
         files={P: ini("[table]", "ball_radius = 1e-400")}),
    Case("ini_negative_count", RUN, USAGE, (P + ":2:", "forest.trees"), files={P: ini("[forest]", "trees = -3")}),
    Case("ini_zero_count", RUN, USAGE, (P + ":2:", "experiment.repetitions"),
         files={P: ini("[experiment]", "repetitions = 0")}),
    Case("ini_zero_balls", RUN, USAGE, (P + ":2:", "table.balls"), files={P: ini("[table]", "balls = 0")}),
    Case("ini_integer_overflow", RUN, USAGE, (P + ":2:", "experiment.seed"),
         files={P: ini("[experiment]", "seed = 99999999999999999999999")}),
    Case("ini_not_an_integer", RUN, USAGE, (P + ":2:", "forest.cuts"), files={P: ini("[forest]", "cuts = 2.5")}),
    Case("ini_trailing_junk", RUN, USAGE, (P + ":2:", "table.friction"),
         files={P: ini("[table]", "friction = 0.25kg")}),
    Case("ini_duplicate_key", RUN, USAGE, (P + ":3:", "table.friction", "line 2"),
         files={P: ini("[table]", "friction = 0.3", "friction = 0.4")}),
    Case("ini_unknown_key", RUN, USAGE, (P + ":3:", "table.frictoin"),
         files={P: ini("[table]", "friction = 0.3", "frictoin = 0.4")}),
    Case("ini_unknown_section", RUN, USAGE, (P + ":1:", "tabel"), files={P: ini("[tabel]", "friction = 0.3")}),
    Case("ini_key_outside_section", RUN, USAGE, (P + ":1:", "friction"), files={P: ini("friction = 0.3")}),
    Case("ini_bad_choice", RUN, USAGE, (P + ":2:", "sim.mode"), files={P: ini("[sim]", "mode = fast")}),
    Case("ini_bad_pocket_list", RUN, USAGE, (P + ":2:", "reward.targets"),
         files={P: ini("[reward]", "targets = 2,7")}),
    Case("ini_extremely_long_line", RUN, USAGE, (P + ":2:",),
         files={P: b"[table]\nfriction = 0." + b"1" * 100000 + b"\n"}),
    Case("ini_crlf_with_error", RUN, USAGE, (P + ":3:", "table.restitution"),
         files={P: b"[table]\r\nfriction = 0.25\r\nrestitution = 2\r\n"}),
    Case("ini_box_outside_table", RUN, USAGE, (P, "start.reward_box"),
         files={P: ini("[start]", "reward_box = 0.4,0.6,0,0.1")}),
    Case("ini_more_reward_balls_than_balls", RUN, USAGE, (P, "table.reward_balls"),
         files={P: ini("[table]", "balls = 2", "reward_balls = 2")}),
    # absurd sizes are refused before any work starts
    Case("ini_absurd_trees", RUN, USAGE, (P + ":2:", "forest.trees"),
         files={P: ini("[forest]", "trees = 1000000000000")}),
    Case("ini_absurd_balls", RUN, USAGE, (P + ":2:", "table.balls"),
         files={P: ini("[table]", "balls = 1000000000")}),
    Case("ini_absurd_iterations", RUN, USAGE, (P + ":2:", "exp3.iterations"),
         files={P: ini("[exp3]", "iterations = 1000000000")}),
    Case("ini_absurd_solver_iterations", RUN, USAGE, (P + ":2:", "reps.max_iter"),
         files={P: ini("[reps]", "max_iter = 1000000000")}),
    Case("ini_absurd_time_steps", SHOOT_C, USAGE, (P, "sim.dt"),
         files={P: ini("[sim]", "mode = stepped", "dt = 1e-7", "max_time = 1e6"), "in.csv": GOOD_CSV}),

    # ---- CSV input (the shoot command) -----------------------------------
    Case("csv_missing", ["shoot", "-i", "nope.csv", "-o", "out.csv"], IO, ("nope.csv", "cannot open")),
    Case("csv_parent_not_a_folder", ["shoot", "-i", "afile/in.csv", "-o", "out.csv"], IO,
         ("afile/in.csv",), files={"afile": b"x"}),
    Case("csv_unreadable", SHOOT, IO, ("in.csv", "ermission denied"), files={"in.csv": GOOD_CSV},
         setup=chmod000("in.csv"), root_ok=False),
    Case("csv_is_a_folder", SHOOT, IO, ("in.csv", "directory"), setup=mkdir("in.csv")),
    Case("csv_empty", SHOOT, IO, ("in.csv", "empty"), files={"in.csv": b""}),
    Case("csv_blank_lines_only", SHOOT, IO, ("in.csv",), files={"in.csv": b"\n\r\n\n"}),
    Case("csv_binary_junk", SHOOT, IO, ("in.csv",), files={"in.csv": junk(2, 4000)}),
    Case("csv_nul_byte", SHOOT, IO, ("in.csv:2:",), files={"in.csv": SHOT_HEADER + b"-0.25,0,0.25,0,0.5\0,0\n"}),
    Case("csv_truncated_row", SHOOT, IO, ("in.csv:4:",), files={"in.csv": GOOD_CSV + b"-0.25,0,0.2"}),
    Case("csv_too_few_fields", SHOOT, IO, ("in.csv:3:",), files={"in.csv": shots("-0.25,0,0.25,0,0.5,0", "1,2,3,4,5")}),
    Case("csv_too_many_fields", SHOOT, IO, ("in.csv:2:",), files={"in.csv": shots("-0.25,0,0.25,0,0.5,0,7")}),
    Case("csv_not_a_number", SHOOT, IO, ("in.csv:2:", "vx"), files={"in.csv": shots("-0.25,0,0.25,0,fast,0")}),
    Case("csv_nan", SHOOT, IO, ("in.csv:2:", "vy"), files={"in.csv": shots("-0.25,0,0.25,0,0.5,nan")}),
    Case("csv_inf", SHOOT, IO, ("in.csv:2:", "x1"), files={"in.csv": shots("-0.25,0,inf,0,0.5,0")}),
    Case("csv_minus_inf", SHOOT, IO, ("in.csv:2:", "y1"), files={"in.csv": shots("-0.25,0,0.25,-inf,0.5,0")}),
    Case("csv_number_too_large", SHOOT, IO, ("in.csv:2:", "vx"), files={"in.csv": shots("-0.25,0,0.25,0,1e400,0")}),
    Case("csv_number_too_small", SHOOT, IO, ("in.csv:2:", "y0"), files={"in.csv": shots("-0.25,1e-400,0.25,0,0.5,0")}),
    Case("csv_empty_field", SHOOT, IO, ("in.csv:2:", "vx"), files={"in.csv": shots("-0.25,0,0.25,0,,0")}),
    Case("csv_extremely_long_field", SHOOT, IO, ("in.csv:2:",),
         files={"in.csv": SHOT_HEADER + b"-0.25,0,0.25,0,0." + b"1" * 10000 + b",0\n"}),
    Case("csv_extremely_long_line", SHOOT, IO, ("in.csv:2:",),
         files={"in.csv": SHOT_HEADER + b"0," * 60000 + b"0\n"}),
    Case("csv_crlf_with_error", SHOOT, IO, ("in.csv:3:", "vx"),
         files={"in.csv": b"x0,y0,x1,y1,vx,vy\r\n-0.25,0,0.25,0,0.5,0\r\n-0.25,0,0.25,0,x,0\r\n"}),
    Case("csv_missing_column", SHOOT, IO, ("in.csv", "vy"), files={"in.csv": b"x0,y0,x1,y1,vx,vz\n1,2,3,4,5,6\n"}),
    Case("csv_odd_column_count", SHOOT, IO, ("in.csv",), files={"in.csv": b"x0,y0,x1,y1,vx\n1,2,3,4,5\n"}),
    Case("csv_duplicate_header", SHOOT, IO, ("in.csv:1:", "vx"), files={"in.csv": b"x0,y0,x1,y1,vx,vx\n1,2,3,4,5,6\n"}),
    Case("csv_empty_header_name", SHOOT, IO, ("in.csv:1:",), files={"in.csv": b"x0,,x1,y1,vx,vy\n1,2,3,4,5,6\n"}),
    Case("csv_unterminated_quote", SHOOT, IO, ("in.csv",), files={"in.csv": b'x0,y0,x1,y1,vx,"vy\n1,2,3,4,5,6\n'}),
    Case("csv_stray_quote", SHOOT, IO, ("in.csv:2:",), files={"in.csv": shots('-0.25,0,0.25,0,"0.5"x,0')}),
    Case("csv_quoted_line_break_in_number", SHOOT, IO, ("in.csv:3:", "vx"),
         files={"in.csv": SHOT_HEADER + b'-0.25,0,0.25,0,"0.5\n1",0\n'}),
    Case("csv_bad_stdin", ["shoot", "-i", "-", "-o", "out.csv", "-q"], IO, ("<stdin>:2:",),
         stdin=SHOT_HEADER + b"a,b,c,d,e,f\n"),
    Case("shoot_too_many_balls", SHOOT, USAGE, ("in.csv",),
         files={"in.csv": ",".join(f"x{i},y{i}" for i in range(10001)).encode() + b",vx,vy\n"}),
    Case("shoot_one_ball", SHOOT, USAGE, ("in.csv",), files={"in.csv": b"x0,y0,vx,vy\n0,0,1,0\n"}),
    Case("shoot_absurd_speed", SHOOT, USAGE, ("in.csv:2:",), files={"in.csv": shots("-0.25,0,0.25,0,1000,0")}),
    Case("shoot_huge_speed", SHOOT, USAGE, ("in.csv:3:",),
         files={"in.csv": shots("-0.25,0,0.25,0,0.5,0", "-0.25,0,0.25,0,1e300,-1e300")}),
    Case("shoot_ball_off_table", SHOOT, USAGE, ("in.csv:2:",), files={"in.csv": shots("5,0,0.25,0,0.5,0")}),
    Case("shoot_balls_overlap", SHOOT, USAGE, ("in.csv:2:",), files={"in.csv": shots("0.25,0,0.25,0.01,0.5,0")}),
    Case("shoot_bad_row_after_good_ones", SHOOT, USAGE, ("in.csv:202:",),
         files={"in.csv": SHOT_HEADER + GOOD_ROW * 200 + b"9,9,0.25,0,0.5,0\n"}),
    Case("shoot_output_folder_missing", ["shoot", "-i", "in.csv", "-o", "nodir/out.csv", "-q"], IO,
         ("nodir/out.csv",), files={"in.csv": GOOD_CSV}),
    Case("shoot_trace_folder_missing",
         ["shoot", "-i", "in.csv", "-o", "out.csv", "--trace", "nodir/t.csv", "-q"], IO,
         ("nodir/t.csv",), files={"in.csv": GOOD_CSV}),

    # ---- command lines ----------------------------------------------------
    Case("cli_unknown_option", ["shoot", "--frobnicate"], USAGE, ("--frobnicate",)),
    Case("cli_unknown_short_option", ["-Z", "p.ini"], USAGE, ("-Z",)),
    Case("cli_unknown_option_in_group", ["shoot", "-Zq"], USAGE, ("-Z",)),
    Case("cli_missing_option_value", ["shoot", "-i", "in.csv", "-o"], USAGE, ("-o",), files={"in.csv": GOOD_CSV}),
    Case("cli_option_of_another_command", ["shoot", "--train", "x.csv"], USAGE, ("--train",)),
    Case("cli_unexpected_argument", ["shoot", "-i", "in.csv", "extra"], USAGE, ("extra",)),
    Case("cli_run_without_config", ["run"], USAGE, ("run",)),
    Case("cli_set_without_equals", ["config", "--set", "table.friction"], USAGE, ("table.friction",)),
    Case("cli_set_unknown_key", ["config", "--set", "table.frictoin=1"], USAGE, ("table.frictoin",)),
    Case("cli_set_nan", SHOOT + ["--set", "table.friction=nan"], USAGE, ("table.friction",),
         files={"in.csv": GOOD_CSV}),
    Case("cli_set_absurd_trees", FOREST + ["--set", "forest.trees=1000000000000"], USAGE, ("forest.trees",),
         files={"train.csv": TRAIN_CSV, "test.csv": TRAIN_CSV}),
    Case("cli_set_line_break", ["config", "--set", "table.friction=0.2\nx"], USAGE, ("--set",)),
    Case("cli_seed_negative", ["config", "--seed", "-1"], USAGE, ("--seed",)),
    Case("cli_seed_junk", ["config", "--seed", "12abc"], USAGE, ("--seed",)),
    Case("cli_seed_too_large", ["config", "--seed", "99999999999999999999"], USAGE, ("--seed",)),
    Case("cli_empty_output_folder", ["run", "p.ini", "-o", "", "-q"], USAGE, ("empty",), files={P: GOOD_INI}),
    Case("cli_merge_without_inputs", ["merge", "-o", "outdir"], USAGE, ("merge",)),
    Case("cli_merge_missing_input", ["merge", "-o", "outdir", "nodir"], IO, ("nodir/config.ini",)),

    # ---- reps, forest, policy ----------------------------------------------
    Case("reps_epsilon_zero", REPS + ["--epsilon", "0"], USAGE, ("--epsilon",), files={"r.csv": REPS_CSV}),
    Case("reps_epsilon_nan", REPS + ["--epsilon", "nan"], USAGE, ("--epsilon",), files={"r.csv": REPS_CSV}),
    Case("reps_epsilon_inf", REPS + ["--epsilon", "inf"], USAGE, ("--epsilon",), files={"r.csv": REPS_CSV}),
    Case("reps_missing_return_column", REPS[:2] + ["S"] + REPS[3:], IO, ("r.csv", "'S'"),
         files={"r.csv": REPS_CSV}),
    Case("reps_nan_return", REPS, IO, ("r.csv:3:", "R"),
         files={"r.csv": b"R,phi0\n-1,1\nnan,1\n"}),
    Case("reps_negative_base_weight", REPS + ["--base", "q"], USAGE, ("r.csv:4:", "q"),
         files={"r.csv": b"R,phi0,q\n-1,1,1\n-2,1,1\n-3,1,-1\n"}),
    Case("reps_no_rows", REPS, IO, ("r.csv",), files={"r.csv": b"R,phi0,phi1\n"}),
    Case("forest_missing_train", ["forest", "--train", "nope.csv", "--test", "test.csv", "--target", "a0",
                                  "-o", "out.csv", "-q"], IO, ("nope.csv",),
         files={"test.csv": TRAIN_CSV}),
    Case("forest_unknown_target", FOREST[:6] + ["zz"] + FOREST[7:], IO, ("train.csv", "zz"),
         files={"train.csv": TRAIN_CSV, "test.csv": TRAIN_CSV}),
    Case("forest_test_lacks_input_column", FOREST, IO, ("test.csv", "s1"),
         files={"train.csv": TRAIN_CSV, "test.csv": b"s0,a0,a1\n1,2,3\n"}),
    Case("forest_malformed_test", FOREST, IO, ("test.csv:2:",),
         files={"train.csv": TRAIN_CSV, "test.csv": b"s0,s1\n1,2,3\n"}),
    Case("policy_negative_weight", POLICY, USAGE, ("train.csv:3:", "w"),
         files={"train.csv": b"s0,s1,a0,a1,w\n0,0,1,1,1\n1,1,2,2,-1\n", "states.csv": STATES_CSV}),
    Case("policy_missing_weight_column", POLICY[:8] + ["ww"] + POLICY[9:], IO, ("train.csv", "ww"),
         files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_states_lack_column", POLICY, IO, ("states.csv", "s1"),
         files={"train.csv": TRAIN_CSV, "states.csv": b"s0\n0.1\n"}),
    Case("policy_sample_zero", POLICY + ["--sample", "0"], USAGE, ("--sample",),
         files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_sample_absurd", POLICY + ["--sample", "1000000000"], USAGE, ("--sample",),
         files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_old_without_means", POLICY + ["--set", "policy.cov_center=old"], USAGE,
         ("policy.cov_center", "--old-mean"),
         files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_means_without_old", POLICY + ["--old-mean", "a0,a1"], USAGE,
         ("--old-mean", "policy.cov_center"),
         files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_old_mean_missing_column", POLICY + ["--old-mean", "m0,m1", "--set", "policy.cov_center=old"],
         IO, ("train.csv", "m0"), files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_old_mean_count", POLICY + ["--old-mean", "a0", "--set", "policy.cov_center=old"], USAGE,
         ("train.csv", "--old-mean"), files={"train.csv": TRAIN_CSV, "states.csv": STATES_CSV}),
    Case("policy_old_mean_nan", POLICY + ["--old-mean", "m0,m1", "--set", "policy.cov_center=old"], IO,
         ("train.csv:3:", "m1"), files={"train.csv": b"s0,s1,a0,a1,w,m0,m1\n0,0,1,1,1,1,1\n1,1,2,2,1,2,nan\n",
                                        "states.csv": STATES_CSV}),
]


def leftovers(tmp):
    """Temporary or staging files anywhere under tmp."""
    return sorted(str(p.relative_to(tmp)) for p in tmp.rglob("*")
                  if p.name.startswith((".poolreps-tmp-", ".partial-")) or ".tmp." in p.name)


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input(case, tmp_path, poolreps):
    if not case.root_ok and os.geteuid() == 0:
        pytest.skip("root can read any file")
    for name, data in (case.files or {}).items():
        (tmp_path / name).write_bytes(data)
    if case.setup:
        case.setup(tmp_path)
    r = poolreps(case.args, input=case.stdin, cwd=tmp_path, timeout=120)
    err = r.stderr.decode("latin-1")
    assert r.returncode == case.code, f"exit {r.returncode}, expected {case.code}; stderr: {err!r}"
    assert err.startswith("poolreps: "), f"stderr: {err!r}"
    assert err.endswith("\n") and err.count("\n") == 1 and "\r" not in err, \
        f"not exactly one line on stderr: {err!r}"
    for needle in case.needles:
        assert needle in err, f"{needle!r} missing from {err!r}"
    assert not (tmp_path / "out.csv").exists(), "output file written despite the error"
    assert not (tmp_path / "outdir").exists(), "output folder created despite the error"
    assert leftovers(tmp_path) == []


# every command that reads a file, with that file missing
MISSING_INPUT = {
    "run": ["run", "nosuch.ini", "-o", "outdir", "-q"],
    "shoot": ["shoot", "-i", "nosuch.csv", "-o", "out.csv", "-q"],
    "forest": ["forest", "--train", "nosuch.csv", "--test", "nosuch.csv", "--target", "a",
               "-o", "out.csv", "-q"],
    "reps": ["reps", "--return", "R", "-i", "nosuch.csv", "-o", "out.csv", "-q"],
    "policy": ["policy", "--train", "nosuch.csv", "--state", "s", "--action", "a",
               "-i", "nosuch.csv", "-o", "out.csv", "-q"],
    "config": ["config", "-c", "nosuch.ini", "-o", "out.csv", "-q"],
    "merge": ["merge", "-o", "outdir", "nosuch", "-q"],
    "sweep": ["sweep", "nosuch.ini", "-o", "outdir", "-q"],
    "collect": ["collect", "nosuch", "-q"],
    "learner": ["learner", "ask", "nosuch.state", "-i", "nosuch.csv", "-o", "out.csv", "-q"],
}


def test_every_command_refuses_a_missing_input(tmp_path, poolreps):
    """Each command `poolreps --help` lists, given an input that does not
    exist: the bad-input contract (one line naming the file, no output)."""
    help_text = poolreps(["--help"]).stdout.decode()
    listed = {n.strip("[]") for n in re.findall(r"^  poolreps (\[run\]|[a-z]+) ", help_text, re.M)}
    assert listed == set(MISSING_INPUT), "a command without a missing-input case"
    for cmd, args in MISSING_INPUT.items():
        r = poolreps(args, input=b"", cwd=tmp_path)
        err = r.stderr.decode("latin-1")
        assert r.returncode in (1, 2), (cmd, r.returncode, err)
        assert err.startswith("poolreps: ") and err.count("\n") == 1, (cmd, err)
        assert "nosuch" in err, (cmd, err)
        assert not (tmp_path / "out.csv").exists() and not (tmp_path / "outdir").exists(), cmd
        assert leftovers(tmp_path) == [], cmd


def test_output_onto_folder_keeps_folder(tmp_path, poolreps):
    """-o naming an existing folder: refused, and the folder is left as it was."""
    (tmp_path / "in.csv").write_bytes(GOOD_CSV)
    (tmp_path / "outdir").mkdir()
    (tmp_path / "outdir" / "keep.txt").write_text("mine")
    r = poolreps(["shoot", "-i", "in.csv", "-o", "outdir", "-q"], cwd=tmp_path)
    err = r.stderr.decode("latin-1")
    assert r.returncode == IO, err
    assert err.startswith("poolreps: ") and err.count("\n") == 1 and "outdir" in err
    assert sorted(p.name for p in (tmp_path / "outdir").iterdir()) == ["keep.txt"]
    assert (tmp_path / "outdir" / "keep.txt").read_text() == "mine"
    assert leftovers(tmp_path) == []


def test_failed_shot_keeps_previous_output(tmp_path, poolreps):
    """A failing run leaves an existing output file untouched."""
    (tmp_path / "in.csv").write_bytes(shots("-0.25,0,0.25,0,nan,0"))
    (tmp_path / "out.csv").write_text("old\n")
    r = poolreps(["shoot", "-i", "in.csv", "-o", "out.csv", "-q"], cwd=tmp_path)
    assert r.returncode == IO
    assert (tmp_path / "out.csv").read_text() == "old\n"
    assert leftovers(tmp_path) == []


def test_no_arguments_is_usage_error(poolreps, tmp_path):
    r = poolreps([], cwd=tmp_path)
    assert r.returncode == USAGE
    assert r.stdout == b""
    assert b"Usage" in r.stderr


def test_errors_without_quiet_are_one_line(tmp_path, poolreps):
    """Without -q nothing but the error reaches stderr when input is refused up front."""
    (tmp_path / P).write_bytes(ini("[table]", "friction = -1"))
    (tmp_path / "in.csv").write_bytes(GOOD_CSV)
    for args in (["run", P, "-o", "outdir"], ["shoot", "-c", P, "-i", "in.csv", "-o", "out.csv"]):
        r = poolreps(args, cwd=tmp_path)
        err = r.stderr.decode("latin-1")
        assert r.returncode == USAGE and err.count("\n") == 1 and f"{P}:2: table.friction" in err, err


# ---- valid but odd inputs ------------------------------------------------

ODD_INI = (b"\xef\xbb\xbf; parameters written on another system\r\n"
           b"\r\n"
           b"[table]   \r\n"
           b"friction=0.5\r\n"
           b"  restitution   =   0.7   ; inline comment\r\n"
           b"# a comment line\r\n"
           b"\t[sim]\r\n"
           b"max_time = 60\t\r\n"
           b"[ experiment ]\r\n"
           b"seed = 42")  # no final line end
ODD_INI_AS_SET = ["--set", "table.friction=0.5", "--set", "table.restitution=0.7",
                  "--set", "sim.max_time=60", "--set", "experiment.seed=42"]


def test_odd_parameter_file_reads_like_plain(tmp_path, poolreps):
    (tmp_path / P).write_bytes(ODD_INI)
    odd = poolreps(["config", "-c", P], cwd=tmp_path)
    plain = poolreps(["config"] + ODD_INI_AS_SET, cwd=tmp_path)
    default = poolreps(["config"], cwd=tmp_path)
    assert odd.returncode == 0, odd.stderr
    assert plain.returncode == 0, plain.stderr
    assert odd.stdout == plain.stdout
    assert odd.stdout != default.stdout


def test_odd_parameter_file_drives_a_shot(tmp_path, poolreps):
    (tmp_path / P).write_bytes(ODD_INI)
    (tmp_path / "in.csv").write_bytes(GOOD_CSV)
    odd = poolreps(["shoot", "-c", P, "-i", "in.csv", "-o", "odd.csv", "-q"], cwd=tmp_path)
    # shoot reads no seed: --set refuses a key the command never reads
    plain = poolreps(["shoot", "-i", "in.csv", "-o", "plain.csv", "-q"] + ODD_INI_AS_SET[:-2],
                     cwd=tmp_path)
    assert odd.returncode == 0, odd.stderr
    assert plain.returncode == 0, plain.stderr
    assert (tmp_path / "odd.csv").read_bytes() == (tmp_path / "plain.csv").read_bytes()


def test_long_but_valid_parameter_lines(tmp_path, poolreps):
    """Lines up to a few KiB (long comments, padded values) are fine."""
    text = (b"; " + b"c" * 3000 + b"\n[table]\nfriction = 0.5" + b" " * 1500 + b"\n")
    (tmp_path / P).write_bytes(text)
    long = poolreps(["config", "-c", P], cwd=tmp_path)
    plain = poolreps(["config", "--set", "table.friction=0.5"], cwd=tmp_path)
    assert long.returncode == 0, long.stderr
    assert long.stdout == plain.stdout


ODD_CSV = (b"\xef\xbb\xbf\"vy\" , vx,x0 ,\"y0\",x1,y1\r\n"
           b"\r\n"
           b" 0 ,\"0.5\", -0.25 , 0,0.25,0\r\n"
           b"\"0.1\",0.4,-0.25,\"0\",\"0.25\",0.1\r\n"
           b"\r\n")


def test_odd_csv_reads_like_plain(tmp_path, poolreps):
    (tmp_path / "odd_in.csv").write_bytes(ODD_CSV)
    (tmp_path / "in.csv").write_bytes(GOOD_CSV)
    odd = poolreps(["shoot", "-i", "odd_in.csv", "-o", "odd.csv", "-q"], cwd=tmp_path)
    plain = poolreps(["shoot", "-i", "in.csv", "-o", "plain.csv", "-q"], cwd=tmp_path)
    assert odd.returncode == 0, odd.stderr
    assert plain.returncode == 0, plain.stderr
    out = (tmp_path / "odd.csv").read_bytes()
    assert out == (tmp_path / "plain.csv").read_bytes()
    assert out.count(b"\n") == 3


def test_csv_without_final_line_end_and_stdin(tmp_path, poolreps):
    (tmp_path / "in.csv").write_bytes(GOOD_CSV)
    plain = poolreps(["shoot", "-i", "in.csv", "-q"], cwd=tmp_path)
    piped = poolreps(["shoot", "-q"], input=GOOD_CSV.rstrip(b"\n"), cwd=tmp_path)
    assert plain.returncode == 0 and piped.returncode == 0, piped.stderr
    assert piped.stdout == plain.stdout
    assert plain.stdout.count(b"\n") == 3


def test_subnormal_numbers_are_numbers(tmp_path, poolreps):
    """5e-324 is finite (the writer may print such values): it must read."""
    (tmp_path / "in.csv").write_bytes(shots("-0.25,5e-324,0.25,0,0.5,-4.9e-320"))
    r = poolreps(["shoot", "-i", "in.csv", "-o", "out.csv", "-q"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert len((tmp_path / "out.csv").read_bytes().splitlines()) == 2


def test_trace_onto_output_is_refused(tmp_path, poolreps):
    """--trace naming the -o file: refused, and nothing written."""
    (tmp_path / "in.csv").write_bytes(GOOD_CSV)
    r = poolreps(["shoot", "-i", "in.csv", "-o", "out.csv", "--trace", "out.csv", "-q"], cwd=tmp_path)
    err = r.stderr.decode("latin-1")
    assert r.returncode in (USAGE, IO), err
    assert err.startswith("poolreps: ") and err.count("\n") == 1 and "out.csv" in err
    assert not (tmp_path / "out.csv").exists()
    assert leftovers(tmp_path) == []


def test_header_only_csv_gives_header_only(tmp_path, poolreps):
    (tmp_path / "in.csv").write_bytes(SHOT_HEADER)
    r = poolreps(["shoot", "-i", "in.csv", "-o", "out.csv", "-q"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = (tmp_path / "out.csv").read_bytes().splitlines()
    assert len(lines) == 1 and lines[0].startswith(b"x0,y0,x1,y1,pocket0,pocket1,")


def test_merge_of_header_only_raw_csvs(tmp_path, poolreps):
    """Raw CSVs without rows merge to a header (this once passed NULL to qsort)."""
    for k in (0, 1):
        cfg = poolreps(["config", "--set", "experiment.name=figures", "--set",
                        "experiment.repetitions=2", "--set", f"experiment.repetition={k}"])
        assert cfg.returncode == 0, cfg.stderr
        (tmp_path / f"r{k}").mkdir()
        (tmp_path / f"r{k}" / "config.ini").write_bytes(cfg.stdout)
        (tmp_path / f"r{k}" / "raw.csv").write_bytes(b"repetition,x\n")
        # a finished run: merge refuses a folder without it
        (tmp_path / f"r{k}" / "provenance.txt").write_bytes(b"version: test\n")
    r = poolreps(["merge", "-q", "-o", "merged", "r0", "r1"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "merged" / "raw.csv").read_bytes() == b"repetition,x\n"
    assert leftovers(tmp_path) == []
