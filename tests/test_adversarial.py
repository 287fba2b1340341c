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

from conftest import ROOT, owner_tag
from test_safety import (IN, IO, OK, RUN_Q, SAN, USAGE, Case, binary, copy_runs, edit_file, env,
                         leftovers, one_line, peak_kib, run, runs, snapshot, wait_for)
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


POLICY_Q = ["policy", "--train", "p.csv", "--weight", "w", "-i", "p.csv", "-q"]
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

    # 7. --progress: only run reports progress, and -q would silence it
    Case("c7_progress_on_a_command_without_progress", ["config", "--progress", "-o", "old.csv"], USAGE,
         ("--progress does not apply",), IN),
    Case("c7_progress_and_quiet", ["run"] + RUN_Q + ["--progress", "-o", "new"], USAGE,
         ("-q and --progress contradict",)),

    # 7. a run never reads another experiment's keys: a --set or --grid of one is refused
    Case("c7_run_set_key_of_another_experiment", ["run"] + RUN_Q + ["-o", "new", "--set",
                                                               "exp3.iterations=5"], USAGE,
         ("--set exp3.iterations does not apply", "quadratic")),
    Case("c7_figures_run_set_bench_key", ["run", ROOT / "data" / "figures.ini", "-q", "-o", "new",
                                          "--set", "bench.iterations=3"], USAGE,
         ("--set bench.iterations does not apply", "figures")),
    Case("c7_sweep_grid_key_of_another_experiment", ["sweep", QUAD, "--grid", "exp1.train=10,20",
                                                     "-o", "sw"] + SWEEP_Q, USAGE,
         ("--grid exp1.train does not apply", "quadratic")),
    # exp4 reads exp3's keys (its learner), but not exp1's
    Case("c7_exp4_run_set_exp1_key", ["run", ROOT / "data" / "exp4.ini", "-q", "-o", "new",
                                      "--set", "exp3.iterations=2", "--set", "exp1.train=10"], USAGE,
         ("--set exp1.train does not apply", "exp4")),
    Case("c7_run_keeps_folder_on_key_of_another_experiment",
         ["run"] + RUN_Q + ["-o", "full", "--set", " exp2.sizes = 10,20"], USAGE,
         ("exp2.sizes does not apply",), {}, copy_runs("full")),

    # 10. a list key refuses a value listed twice (a sweep's variants would
    # share one output folder; a summary would hold one setting twice)
    Case("c10_list_value_twice_set", ["config", "--set", "exp1.trees_list=10,10"], USAGE,
         ("exp1.trees_list", "10 listed twice")),
    Case("c10_list_value_twice_file", ["config", "-c", "l.ini", "-o", "old.csv"], USAGE,
         ("l.ini:2", "exp2.sizes", "20 listed twice"), dict(IN, **{"l.ini": b"[exp2]\nsizes = 20, 50,20\n"})),
    Case("c10_list_big_value_twice", ["config", "--set", "exp2.sizes=10000000,10000000"], USAGE,
         ("10000000 listed twice",)),

    # 9. an output poolreps could not read back: two columns of one name
    Case("c9_policy_state_listed_twice", POLICY_Q + ["--state", "s0,s0", "--action", "a0", "-o", "old.csv"],
         IO, ("p.csv", "column 's0' selected twice"), IN),
    Case("c9_policy_action_listed_twice", POLICY_Q + ["--state", "s0", "--action", "a0,a0"], IO,
         ("column 'a0' selected twice",), IN),
    Case("c9_reps_feature_by_prefix_and_name", ["reps", "--return", "R", "--features", "phi*,phi0", "-i",
                                                "r.csv", "-q", "-o", "old.csv"], IO,
         ("column 'phi0' selected twice by 'phi*,phi0'",), IN),
    Case("c7_policy_state_is_the_action", POLICY_Q + ["--state", "s0", "--action", "s0"], USAGE,
         ("column 's0' is both a state and an action",), IN),
    Case("c7_policy_weight_is_the_action", ["policy", "--train", "p.csv", "--state", "s0", "--action", "a0",
                                            "--weight", "a0", "-i", "p.csv", "-q"], USAGE,
         ("column 'a0' is both the weight and an action",), IN),

    # 10. config refuses a variant the experiment does not have, as a run would
    Case("c10_config_variant_without_variants", ["config", "-c", QUAD, "--set", "experiment.variant=0",
                                                 "-o", "old.csv"], USAGE,
         ("experiment.variant", "quadratic has no variants"), IN),
    Case("c10_config_variant_past_the_last", ["config", "-c", ROOT / "data" / "exp3.ini", "--set",
                                              "exp3.policies=baseline,handcrafted", "--set",
                                              "experiment.variant=2"], USAGE,
         ("experiment.variant: 2", "2 variants (0..1)")),

    # 9. a run folder's files keep their permission bits (and owner, for root)
    Case("c9_run_keeps_modes", ["run"] + RUN_Q + ["-o", "full", "--seed", "5"], OK, (), {},
         None, writes=tuple("full/" + f for f in RUN_FILES), lines=0),
    Case("c9_merge_keeps_modes", ["merge", "-q", "-o", "full", "r0", "r1"], OK, (), {},
         None, writes=("full/provenance.txt",), lines=0),

    # 3. weights whose sum overflows would make every share 0: refused as a parameter error
    Case("c3_policy_weights_sum_overflows", ["policy", "--train", "w.csv", "--state", "s0", "--action",
                                             "a0", "--weight", "w", "-i", "w.csv", "-q", "-o", "old.csv"],
         USAGE, ("w.csv", "column 'w'", "sum past the largest number"),
         dict(IN, **{"w.csv": b"s0,a0,w\n0,1,1e308\n1,2,1e308\n2,1,1e308\n"})),
    Case("c3_forest_weights_sum_overflows", ["forest", "--train", "w.csv", "--test", "w.csv", "--target",
                                             "y", "--weight", "w", "-q", "-o", "old.csv"],
         USAGE, ("w.csv", "column 'w'", "sum past"), dict(IN, **{"w.csv": b"s,y,w\n0,1,1e308\n1,2,1e308\n"})),
    Case("c3_reps_base_sum_overflows", ["reps", "--return", "R", "--features", "phi0", "--base", "b",
                                        "-i", "w.csv", "-q", "--summary", "old.csv"],
         USAGE, ("column 'b'", "base weights sum past"),
         dict(IN, **{"w.csv": b"R,phi0,b\n1,1,1e308\n2,2,1e308\n"})),

    # 3. an empty output name is a usage error for every command (config -o too)
    Case("c3_config_empty_output_is_usage", ["config", "-o", ""], USAGE, ("output file name is empty",)),
    Case("c3_shoot_empty_trace_is_usage", ["shoot", "-i", "s.csv", "--trace", ""], USAGE, ("empty",), IN),

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


# ---- collect: a sweep folder is published like a run folder ----

@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    """A sweep of 2 points x 2 repetitions whose jobs ran ("s"), the same
    collected ("c"), and one of 30 points (a collect long enough to signal)."""
    base = tmp_path_factory.mktemp("sweeps")
    for name, values in (("s", "30,40"), ("big", ",".join(str(v) for v in range(20, 50)))):
        r = run(["sweep", QUAD, "--grid", f"bench.samples={values}", "-o", base / name] + SWEEP_Q, base)
        assert r.returncode == 0, r.stderr
        jobs = (base / name / "jobs.txt").read_text()
        done = subprocess.run(["sh", "-e"], input=jobs.encode(), capture_output=True, timeout=600)
        assert done.returncode == 0, done.stderr
    shutil.copytree(base / "s", base / "c", symlinks=True)
    r = run(["collect", base / "c"], base)
    assert r.returncode == 0, r.stderr
    return base


def sweep_copy(name, edit=None):
    def f(tmp, sweeps):
        shutil.copytree(sweeps / name, tmp / "s", symlinks=True)
        if edit:
            edit(tmp / "s")
    return f


MERGED_PROV = ("s/point-0/merged/provenance.txt", "s/point-1/merged/provenance.txt")
COLLECT = ["collect", "s"]

COLLECT_CASES = [
    Case("c1_collect_summary_is_a_folder", COLLECT, IO, ("s/sweep_summary.csv", "is a folder"), {},
         sweep_copy("s", lambda s: (s / "sweep_summary.csv").mkdir())),
    Case("c1_collect_merged_is_a_file", COLLECT, IO, ("s/point-1/merged", "not a folder"), {},
         sweep_copy("s", lambda s: (s / "point-1" / "merged").write_bytes(b"mine\n"))),
    Case("c1_collect_again_merged_file_is_a_folder", COLLECT, IO,
         ("s/point-1/merged/bench_curve.csv", "is a folder"), {},
         sweep_copy("c", lambda s: ((s / "point-1" / "merged" / "bench_curve.csv").unlink(),
                                    (s / "point-1" / "merged" / "bench_curve.csv").mkdir()))),
    Case("c2_collect_row_repeated", COLLECT, IO, ("s/point-1/runs/rep-1/bench_curve.csv", "4 rows"), {},
         sweep_copy("c", lines_of("point-1/runs/rep-1/bench_curve.csv", repeat_second))),
    Case("c2_collect_job_without_provenance", COLLECT, IO, ("job 3", "incomplete"), {},
         sweep_copy("c", lambda s: (s / "point-1" / "runs" / "rep-1" / "provenance.txt").unlink())),
    # the manifest's grid values label the summary rows: they must be what the point ran
    Case("c2_collect_manifest_value_edited", COLLECT, IO,
         ("s/manifest.csv:4", "'41'", "the jobs of point 1 ran bench.samples = 40"), {},
         sweep_copy("c", edit_file("manifest.csv", lambda b: b.replace(b",40,", b",41,")))),
    Case("c2_collect_manifest_value_not_a_number", COLLECT, IO, ("s/manifest.csv:2", "not an integer"),
         {}, sweep_copy("s", edit_file("manifest.csv", lambda b: b.replace(b",30,", b",3x,", 1)))),
    Case("c2_collect_manifest_key_edited", COLLECT, IO, ("s/manifest.csv:2", "bench.sample", "unknown key"),
         {}, sweep_copy("s", edit_file("manifest.csv", lambda b: b.replace(b"bench.samples", b"bench.sample")))),
    # 4. bounded reading of every file collect and sweep --missing read
    Case("c4_collect_sweep_config_dev_zero", COLLECT, USAGE, ("s/config.ini:1", "NUL"), {},
         sweep_copy("s", lambda s: ((s / "config.ini").unlink(),
                                    (s / "config.ini").symlink_to("/dev/zero")))),
    Case("c4_sweep_missing_jobs_dev_zero", ["sweep", "--missing", "s"], IO, ("s/jobs.txt:1", "NUL"), {},
         sweep_copy("s", lambda s: ((s / "jobs.txt").unlink(), (s / "jobs.txt").symlink_to("/dev/zero")))),
    Case("c4_sweep_missing_endless_job_line", ["sweep", "--missing", "s"], IO,
         ("s/jobs.txt:2", "longer than"), {},
         sweep_copy("s", lambda s: (s / "jobs.txt").write_bytes(b"sh x\n" + b"a" * 100000 + b"\n"))),
    Case("c1_collect_sweep_config_differs_names_the_key", COLLECT, USAGE,
         ("s/config.ini", "differs", "point 0", "bench.iterations = 4, jobs: 3"), {},
         sweep_copy("s", edit_file("config.ini", lambda b: b.replace(b"iterations = 3", b"iterations = 4")))),
    Case("c6_collect_again_keeps_files_it_did_not_write", COLLECT, OK, (), {},
         sweep_copy("c", lambda s: ((s / "point-0" / "merged" / "fig.png").write_bytes(b"png"),
                                    (s / "notes.txt").write_bytes(b"mine\n"))),
         writes=MERGED_PROV, lines=0),
    Case("c9_collect_again_keeps_modes", COLLECT, OK, (), {},
         sweep_copy("c", lambda s: (os.chmod(s / "sweep_summary.csv", 0o600),
                                    os.chmod(s / "point-0" / "merged" / "provenance.txt", 0o640))),
         writes=MERGED_PROV, lines=0),
]


@pytest.mark.parametrize("case", COLLECT_CASES, ids=[c.id for c in COLLECT_CASES])
def test_collect_case(case, tmp_path, sweeps):
    _check_case(case, tmp_path, sweeps)


def dead_pid():
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def test_collect_removes_what_sigkill_left(tmp_path, sweeps):
    """A collect killed with SIGKILL leaves its staging folder (with
    folders in it); the next collect removes it once that PID is gone."""
    shutil.copytree(sweeps / "s", tmp_path / "s", symlinks=True)
    stale = tmp_path / "s" / f".partial-{owner_tag(dead_pid())}"
    (stale / "point-0" / f".partial-{owner_tag(dead_pid())}").mkdir(parents=True)
    (stale / "point-0" / "bench_curve.csv").write_bytes(b"x\n")
    (stale / "summary").mkdir()
    r = run(COLLECT, tmp_path)
    assert r.returncode == OK, r.stderr
    assert not leftovers(tmp_path), leftovers(tmp_path)


@pytest.mark.parametrize("sigs", [(signal.SIGTERM,), (signal.SIGHUP,), (signal.SIGQUIT,),
                                  (signal.SIGUSR2,), (signal.SIGTERM, signal.SIGINT)],
                         ids=["TERM", "HUP", "QUIT", "USR2", "TERM_then_INT"])
def test_signal_mid_collect(sigs, tmp_path, sweeps):
    """Mid-collect, one signal (the loops stop) or a second one (the handler
    removes the nested staging folders at once): the sweep folder is as it was."""
    shutil.copytree(sweeps / "big", tmp_path / "s", symlinks=True)
    before = snapshot(tmp_path)
    p = subprocess.Popen([binary(), "collect", "s"], cwd=tmp_path, env=env(),
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        assert wait_for(lambda: any(e.name.startswith(".partial-") for e in os.scandir(tmp_path / "s")),
                        60), "no staging folder appeared"
        for s in sigs:   # back to back: the second finds the first still being handled
            p.send_signal(s)
        _, err = p.communicate(timeout=60)
    finally:
        p.kill()
        p.wait()
    if p.returncode == OK:
        pytest.skip("collect finished before the signal")
    assert p.returncode in [128 + s for s in sigs], err
    assert err.count(b"\n") == 1, err
    assert snapshot(tmp_path) == before


@pytest.mark.native
@pytest.mark.skipif(os.geteuid() != 0, reason="switching to an unprivileged user needs root")
@pytest.mark.parametrize("target", ["summary", "merged_file", "point_folder"])
def test_collect_read_only_for_a_non_root_user(target, sweeps):
    """A read-only sweep_summary.csv or merged file is refused; a merged
    folder that cannot take the new files puts back every point already
    moved: nothing changes."""
    if shutil.which("setpriv") is None:
        pytest.skip("setpriv not installed")
    import tempfile
    d = tempfile.mkdtemp(prefix="pr_nobody_")
    try:
        os.chmod(d, 0o777)
        s = os.path.join(d, "s")
        shutil.copytree(sweeps / "c", s, symlinks=True)
        for root, dirs, files in os.walk(d):
            for n in dirs + files:
                os.lchown(os.path.join(root, n), 65534, 65534)
        if target == "summary":
            os.chmod(os.path.join(s, "sweep_summary.csv"), 0o444)
        elif target == "merged_file":
            os.chmod(os.path.join(s, "point-1", "merged", "bench_summary.csv"), 0o444)
        else:
            os.chmod(os.path.join(s, "point-1", "merged"), 0o555)
        before = snapshot(d)
        r = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", binary(),
                            "collect", "s"], cwd=d, env=env(), capture_output=True, timeout=120)
        assert r.returncode == IO, r.stderr
        assert b"Permission denied" in one_line(r).encode()
        assert snapshot(d) == before
    finally:
        shutil.rmtree(d, ignore_errors=True)


@pytest.mark.native
def test_sweep_missing_memory_stays_bounded(tmp_path, sweeps):
    """A jobs.txt of one endless line (/dev/zero): the right message, a
    small peak (no line is read whole into memory)."""
    if SAN:
        pytest.skip("AddressSanitizer's shadow memory and quarantine change the resident size")
    shutil.copytree(sweeps / "s", tmp_path / "s", symlinks=True)
    (tmp_path / "s" / "jobs.txt").unlink()
    (tmp_path / "s" / "jobs.txt").symlink_to("/dev/zero")
    peak, err = peak_kib(["sweep", "--missing", "s"], cwd=tmp_path)
    assert err.count(b"\n") == 1 and b"NUL byte" in err, err
    assert peak < 64 * 1024, f"peak {peak} KiB"


# ---- class 3: an allocation that fails anywhere is exit 4 ----

# Fails every allocation from the FAILAT-th on (malloc, calloc, realloc:
# also those of the C library, libcsv, GSL and GLPK), as when memory runs out;
# with FAILONE set, the FAILAT-th alone. FAILCOUNT=FILE: the number of
# allocations, written there at exit.
FAILMALLOC_C = r"""
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
extern void *__libc_malloc(size_t);
extern void *__libc_calloc(size_t, size_t);
extern void *__libc_realloc(void *, size_t);
static long count, failat = -2;
static int one;
static int fail(void)
{
	long k;

	if (failat == -2) {
		const char *s = getenv("FAILAT");
		failat = s ? atol(s) : -1;
		one = getenv("FAILONE") != NULL;
	}
	k = __atomic_add_fetch(&count, 1, __ATOMIC_SEQ_CST);
	if (failat < 0 || k < failat || (one && k > failat))
		return 0;
	errno = ENOMEM;
	return 1;
}
__attribute__((destructor)) static void report(void)
{
	const char *s = getenv("FAILCOUNT");
	FILE *f = s ? fopen(s, "w") : NULL;

	if (f) {
		fprintf(f, "%ld\n", count);
		fclose(f);
	}
}
void *malloc(size_t n) { return fail() ? NULL : __libc_malloc(n); }
void *calloc(size_t a, size_t b) { return fail() ? NULL : __libc_calloc(a, b); }
void *realloc(void *p, size_t n) { return fail() ? NULL : __libc_realloc(p, n); }
"""


@pytest.fixture(scope="module")
def failmalloc(tmp_path_factory):
    if SAN:
        pytest.skip("the sanitizers' allocator must come first: no LD_PRELOAD")
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler for the allocation-failure shim")
    d = tmp_path_factory.mktemp("failmalloc")
    (d / "failmalloc.c").write_text(FAILMALLOC_C)
    r = subprocess.run([cc, "-shared", "-fPIC", "-O2", "-o", d / "failmalloc.so", d / "failmalloc.c"],
                       capture_output=True)
    if r.returncode:
        pytest.skip("cannot build the shim: " + r.stderr.decode()[:200])
    return d / "failmalloc.so"


def _reps_far(tmp):
    (tmp / "r.csv").write_bytes(REPS_IN)


OOM = [
    ("shoot", ["shoot", "-i", "s.csv", "-o", "old.csv", "--trace", "t.csv"], 1),
    ("forest", ["forest", "--train", "tr.csv", "--test", "tr.csv", "--target", "y", "-q", "-o", "old.csv",
                "--leaves", "l.csv"], 1),
    ("reps_summary", ["reps", "--return", "R", "--features", "phi0", "-i", "r.csv", "-q", "-o", "old.csv",
                      "--summary", "s2.csv"], 1),
    # an unreachable bound: the feature-matching LP (GLPK, which aborts on no memory)
    ("reps_lp", ["reps", "--return", "R", "--features", "phi0", "-i", "r.csv", "-q", "--epsilon", "1e6",
                 "-o", "old.csv"], 1),
    ("policy", ["policy", "--train", "p.csv", "--state", "s0", "--action", "a0", "--weight", "w", "-i",
                "p.csv", "-q", "-o", "old.csv", "--sample", "3"], 13),
    ("config", ["config", "-o", "old.csv"], 1),
    ("merge", ["merge", "-q", "-o", "full", "r0", "r1"], 7),
    ("run", RUN_Q + ["-o", "full", "--seed", "4"], 11),
    ("sweep", ["sweep", QUAD, "--grid", "bench.samples=30,40", "-q", "-o", "sw"], 3),
    ("sweep_missing", ["sweep", "--missing", "s"], 1),
    ("collect", ["collect", "s"], 41),
    # worker threads, policies, forests and GLPK inside an experiment
    ("run_exp3", [ROOT / "data" / "exp3.ini", "-q", "-o", "e3"] +
     [a for kv in ("experiment.repetitions=1", "experiment.threads=2", "exp3.init_samples=40",
                   "exp3.window=40", "exp3.samples=10", "exp3.iterations=2", "exp3.final_episodes=10",
                   "policy.n_min=15", "exp3.baseline_n_min=60", "value.n_min=12",
                   "exp3.policies=nrvr_rs,rvr_a,baseline,handcrafted") for a in ("--set", kv)], 293),
]


@pytest.mark.native
@pytest.mark.parametrize("name,args,step", OOM, ids=[o[0] for o in OOM])
def test_every_allocation_failure_is_out_of_memory(name, args, step, failmalloc, tmp_path, runs, sweeps):
    """The n-th allocation and all after it fail, for n = 1, 1 + step, ...
    until the command no longer needs them: every time exit 4, one line,
    nothing created, changed or removed (staging folders included)."""
    for n, data in IN.items():
        (tmp_path / n).write_bytes(data)
    for n in ("r0", "r1", "full"):
        shutil.copytree(runs / n, tmp_path / n, symlinks=True)
    shutil.copytree(sweeps / "s", tmp_path / "s", symlinks=True)
    (tmp_path / "s" / "point-1" / "runs" / "rep-1" / "provenance.txt").unlink()  # one job not done
    if name == "collect":
        shutil.rmtree(tmp_path / "s")
        shutil.copytree(sweeps / "c", tmp_path / "s", symlinks=True)
    before = snapshot(tmp_path)
    n = 1
    while True:
        r = subprocess.run([binary()] + [str(a) for a in args], cwd=tmp_path, capture_output=True,
                           env=dict(env(), LD_PRELOAD=str(failmalloc), FAILAT=str(n)), timeout=120)
        if r.returncode == OK:
            break
        assert r.returncode == 4, (n, r.stderr)
        one_line(r)
        assert r.stdout == b"" or name == "sweep_missing", (n, r.stdout[:200])
        assert snapshot(tmp_path) == before, n
        n += step
    assert n > 1, "the command allocated nothing"


def wide_reps_table(path, which):
    """A wide dense REPS problem as CSV: `reduced`, whose first attempt (joint
    Newton with chord steps) fails its certificate and whose reduced basis
    (GSL's SVD) certifies; `threads`, large enough for the Hessian's
    threads (n d^2 / 2 >= 2e6 multiply-adds)."""
    import numpy as np
    import reps_families
    if which == "reduced":
        R, _, phi, _ = reps_families.make_family(reps_families.WIDE, 8)
    else:
        rng = np.random.default_rng(12)
        phi = rng.normal(size=(3000, 40)) * 10.0 ** rng.uniform(-2, 2, size=40) + 1e3
        R = phi[:, :3] @ rng.normal(size=3) + rng.standard_t(3, size=3000)
    head = ",".join(["R"] + [f"phi{j}" for j in range(phi.shape[1])])
    np.savetxt(path, np.c_[R, phi], delimiter=",", header=head, comments="", fmt="%.17g")


@pytest.mark.native
@pytest.mark.parametrize("which", ["reduced", "threads"])
def test_allocation_failures_in_a_wide_reps_solve(which, failmalloc, tmp_path):
    """Wide dense REPS (chord steps, the reduced basis and its SVD, the
    Hessian's threads) with allocations failing, at every allocation in
    turn: (1) that one and all after it: exit 4, one line, nothing written;
    (2) that one alone: exit 4 the same way, or exit 0 with the bytes of an
    undisturbed solve (a Hessian thread or its block that cannot be had
    leaves the work to one thread). GSL's SVD allocates inside without
    checking: poolreps' error handler turns that into out of memory."""
    wide_reps_table(tmp_path / "w.csv", which)
    args = [binary(), "reps", "--return", "R", "--features", "phi*", "--epsilon", "0.5", "-i", "w.csv",
            "-q", "-o", "p.csv", "--summary", "s.csv"]
    r = subprocess.run(args, cwd=tmp_path, capture_output=True, env=env(), timeout=120)
    assert r.returncode == OK, r.stderr
    ref = ((tmp_path / "p.csv").read_bytes(), (tmp_path / "s.csv").read_bytes())
    path = ref[1].split(b"\n")[1].split(b",")[-1]
    assert path == (b"joint+chord+reduced" if which == "reduced" else b"joint+chord"), path
    (tmp_path / "p.csv").unlink()
    (tmp_path / "s.csv").unlink()
    before = snapshot(tmp_path)
    r = subprocess.run(args[:-4], cwd=tmp_path, capture_output=True, timeout=120,
                       env=dict(env(), LD_PRELOAD=str(failmalloc), FAILCOUNT=str(tmp_path.parent / "n")))
    total = int((tmp_path.parent / "n").read_text())
    for mode in ({}, {"FAILONE": "1"}):
        for n in range(1, total + 1):
            r = subprocess.run(args, cwd=tmp_path, capture_output=True, timeout=120,
                               env=dict(env(), LD_PRELOAD=str(failmalloc), FAILAT=str(n), **mode))
            if r.returncode == OK and mode:
                assert ((tmp_path / "p.csv").read_bytes(), (tmp_path / "s.csv").read_bytes()) == ref, n
                (tmp_path / "p.csv").unlink()
                (tmp_path / "s.csv").unlink()
                continue
            assert r.returncode == 4, (mode, n, r.returncode, r.stderr)
            one_line(r)
            assert snapshot(tmp_path) == before, (mode, n)


def test_sweep_missing_into_a_closed_pipe_is_sigpipe(tmp_path, sweeps):
    """`sweep --missing DIR | head -0`: the reader is gone before the jobs
    are written: exit 141 (SIGPIPE), one line, as documented."""
    shutil.copytree(sweeps / "s", tmp_path / "s", symlinks=True)
    for prov in (tmp_path / "s").glob("point-*/runs/*/provenance.txt"):
        prov.unlink()
    before = snapshot(tmp_path)
    # the reader is closed before the command starts: closing it after the
    # start raced with the write, which fits in the pipe's buffer
    r, w = os.pipe()
    os.close(r)
    p = subprocess.Popen([binary(), "sweep", "--missing", "s"], cwd=tmp_path, env=env(),
                         stdout=w, stderr=subprocess.PIPE)
    os.close(w)
    err = p.stderr.read()
    p.wait(timeout=60)
    assert p.returncode == 128 + signal.SIGPIPE, err
    assert err.count(b"\n") == 1 and b"signal 13" in err, err
    assert snapshot(tmp_path) == before


def test_sweep_into_a_folder_a_killed_sweep_left(tmp_path):
    """A sweep killed with SIGKILL leaves SWEEP_DIR/.partial-PID: the next
    sweep into the folder removes it (its PID is gone) rather than calling
    the folder not empty; a live sweep's staging still makes it refuse."""
    stale = tmp_path / "sw" / f".partial-{owner_tag(dead_pid())}"
    (stale / "point-0").mkdir(parents=True)
    (stale / "jobs.txt").write_bytes(b"x\n")
    r = run(["sweep", QUAD, "--grid", "bench.samples=30,40", "-o", "sw"] + SWEEP_Q, tmp_path)
    assert r.returncode == OK, r.stderr
    assert not stale.exists() and (tmp_path / "sw" / "jobs.txt").exists()
    live = tmp_path / "sw2" / f".partial-{owner_tag(os.getpid())}"
    live.mkdir(parents=True)
    r = run(["sweep", QUAD, "--grid", "bench.samples=30,40", "-o", "sw2"] + SWEEP_Q, tmp_path)
    assert r.returncode == IO and b"not empty" in one_line(r).encode()
    assert live.exists()
