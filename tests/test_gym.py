"""The Python package as a Gymnasium citizen: registration, rendering,
normalised actions, both checkers, pickling (env, Forest, Policy) and the
forest file format shared with the C library and the CLI, reprs, prompt
Ctrl-C in long calls, the environment's random streams.

Tests that need Gymnasium (not a Debian package) skip without it: `make
venv` builds build/venv with it, and `build/venv/bin/python -m pytest
tests/test_gym.py` runs them all."""
import copy
import os
import pickle
import subprocess
import sys
import textwrap
import time
import warnings

import numpy as np
import pytest

from conftest import ROOT, run_cmd, run_poolreps

sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402

try:
    import gymnasium
except ImportError:
    gymnasium = None
needs_gym = pytest.mark.skipif(gymnasium is None, reason="gymnasium is not installed "
                               "(make venv; build/venv/bin/python -m pytest tests/test_gym.py)")


def child_env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT / "python")
    return env


def run_python(code, timeout=120):
    return run_cmd([sys.executable, "-c", textwrap.dedent(code)], capture_output=True,
                   text=True, env=child_env(), timeout=timeout)


# ---- registration, vector envs -------------------------------------------------

@needs_gym
def test_make_and_make_vec_use_the_registered_id():
    env = gymnasium.make("poolreps/PocketEnv-v0", normalize_actions=True)
    assert isinstance(env.unwrapped, poolreps.PocketEnv)
    obs, _ = env.reset(seed=3)
    assert obs.shape == (4,)
    venv = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=3, vectorization_mode="sync")
    a, _ = venv.reset(seed=7)
    b, _ = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=3,
                              vectorization_mode="sync").reset(seed=7)
    assert np.array_equal(a, b) and a.shape == (3, 4)
    assert len({tuple(r) for r in a}) == 3  # each sub-env its own stream


@needs_gym
def test_make_with_the_module_prefix_needs_no_import():
    p = run_python("""
        import gymnasium
        env = gymnasium.make("poolreps:poolreps/PocketEnv-v0")
        print(type(env.unwrapped).__name__)
    """)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "PocketEnv"


@needs_gym
def test_async_vector_env_with_spawn_matches_sync():
    # pickling the env is what AsyncVectorEnv with spawn needs
    kw = dict(num_envs=2, vectorization_mode="async",
              vector_kwargs={"context": "spawn"})
    p = run_python(f"""
        import gymnasium, numpy as np, poolreps
        if __name__ == "__main__":
            a = gymnasium.make_vec("poolreps/PocketEnv-v0", **{kw!r})
            s = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=2, vectorization_mode="sync")
            x, _ = a.reset(seed=5); y, _ = s.reset(seed=5)
            act = np.array([[0.5, 0.02], [0.3, -0.01]])
            print(np.array_equal(x, y), np.array_equal(a.step(act)[1], s.step(act)[1]))
            a.close()
    """, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["True", "True"]


def test_package_imports_without_gymnasium():
    p = run_python("""
        import sys
        sys.modules["gymnasium"] = None   # import gymnasium now raises ImportError
        import poolreps
        env = poolreps.PocketEnv(normalize_actions=True)
        s, _ = env.reset(seed=1)
        print(type(env.action_space).__name__, env.step([0.05, 0.0])[2])
    """)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["Bounds", "True"]


# ---- rendering -----------------------------------------------------------------

def frame_after_shot(**kw):
    env = poolreps.PocketEnv(render_mode="rgb_array", **kw)
    s, _ = env.reset(seed=2)
    before = env.render()
    env.step([0.615, 0.03])
    return env, s, before, env.render()


def test_rgb_array_draws_table_pockets_balls_and_trajectory():
    env, s, before, after = frame_after_shot()
    r = env._renderer
    assert before.shape == (200, 400, 3) and before.dtype == np.uint8
    for x in (-env.half[0], 0, env.half[0]):
        for y in (-env.half[1], env.half[1]):
            c, row = r._px(x, y)
            assert tuple(before[min(row, 199), min(c, 399)]) == (0, 0, 0), (x, y)  # pockets
    c, row = r._px(s[0], s[1])
    assert tuple(before[row, c]) == (245, 245, 245)  # the cue ball before the shot
    c, row = r._px(s[2], s[3])
    assert tuple(before[row, c]) == (210, 30, 30)  # the reward ball
    c, row = r._px(0.3, 0.1)
    assert tuple(before[row, c]) == (20, 110, 50)  # cloth
    trail = np.all(after == (200, 200, 255), axis=2)
    assert trail.sum() > 50  # the cue ball's path
    assert not np.all(before == (200, 200, 255), axis=2).any()  # none before the shot
    tr = env.trajectory()
    assert tr.shape[1] == 4 and set(tr[:, 3].astype(int)) == {0, 1}
    final = tr[tr[:, 3] == 1][-1, 1:3]
    assert np.array_equal(final, env._last[2][2:4])


def test_rgb_array_is_fast_enough_for_video():
    env, _, _, _ = frame_after_shot()
    env.render()
    n, t0 = 100, time.perf_counter()
    for _ in range(n):
        env.render()  # recomputes the trajectory each time
    fps = n / (time.perf_counter() - t0)
    assert fps >= 100, f"{fps:.0f} frames/s at 400 x 200"


def test_render_mode_is_checked_and_none_renders_nothing():
    with pytest.raises(ValueError, match="render_mode"):
        poolreps.PocketEnv(render_mode="ansi")
    env = poolreps.PocketEnv()
    env.reset(seed=1)
    assert env.render() is None


# ---- normalised actions, both checkers -----------------------------------------

def test_normalised_actions_scale_to_the_speed_box():
    env = poolreps.PocketEnv(normalize_actions=True)
    assert np.array_equal(env.action_space.low, [-1, -1])
    assert np.array_equal(env.action_space.high, [1, 1])
    S, _ = env.reset_batch(50, seed=4)
    a = np.random.default_rng(4).uniform(-0.2, 0.2, (50, 2))
    obs, rew, *_ = env.step_batch(S, a)
    ref = poolreps.shoot(S, a * env.max_speed)
    assert np.array_equal(rew, ref["reward"])
    assert np.array_equal(obs, ref["final"].reshape(50, -1))
    # a corner of the box is faster than sim.max_speed: scaled down to it
    _, _, _, _, info = env.step_batch(S[:1], [[1.0, 1.0]])
    assert info["clipped"][0] and np.hypot(*info["velocity"][0]) <= env.max_speed


@needs_gym
def test_gymnasium_checker_passes_without_warnings():
    from gymnasium.utils.env_checker import check_env
    env = gymnasium.make("poolreps/PocketEnv-v0", normalize_actions=True,
                         render_mode="rgb_array").unwrapped
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        check_env(env)
    assert [str(x.message) for x in w] == []


def test_sb3_checker_passes_without_warnings():
    pytest.importorskip("stable_baselines3", reason="Stable-Baselines3 is not installed "
                        "(make baselines installs it into build/baselines/venv)")
    from stable_baselines3.common.env_checker import check_env
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        check_env(poolreps.PocketEnv(normalize_actions=True, render_mode="rgb_array"))
    assert [str(x.message) for x in w] == []


@pytest.mark.parametrize("action, msg", [
    ([0.1], "action: expected 2 rows"),
    ([[0.1, 0.2]], "action: expected a 1-D array"),
    ([np.nan, 0.0], r"action\[0\]: not a finite number"),
    ([0.0, np.inf], r"action\[1\]: not a finite number"),
])
@pytest.mark.parametrize("normalize", [False, True])
def test_bad_actions_name_the_argument(action, msg, normalize):
    env = poolreps.PocketEnv(normalize_actions=normalize)
    env.reset(seed=1)
    with pytest.raises(ValueError, match=msg):
        env.step(action)


# ---- pickling ------------------------------------------------------------------

def roundtrips(obj):
    return [pickle.loads(pickle.dumps(obj)), copy.deepcopy(obj), copy.copy(obj)]


def test_env_pickles_and_continues_bit_identically():
    env = poolreps.PocketEnv(set={"table.friction": 0.3}, normalize_actions=True,
                             render_mode="rgb_array")
    env.reset(seed=11)
    env.reset_batch(3)
    env.step([0.05, 0.01])  # the last shot (what render draws) travels too
    for twin in roundtrips(env):
        assert np.array_equal(twin.render(), env.render())
    twins = roundtrips(env)
    for _ in range(5):
        x, _ = env.reset()
        for twin in twins:
            y, _ = twin.reset()
            assert np.array_equal(x, y)
        r = env.step([0.05, 0.0])
        for twin in twins:
            q = twin.step([0.05, 0.0])
            assert np.array_equal(r[0], q[0]) and r[1] == q[1]
    assert repr(twins[0]) == repr(env) == ("PocketEnv(set={'table.friction': 0.3}, "
                                           "render_mode='rgb_array', normalize_actions=True)")
    # mid-episode too: the pending start state is kept
    env.reset()
    twin = pickle.loads(pickle.dumps(env))
    assert np.array_equal(env.step([0.1, 0.0])[0], twin.step([0.1, 0.0])[0])


def fitted_forest(seed=0, one_output=True):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (400, 3))
    y = np.sin(3 * X[:, 0]) + X[:, 1] * X[:, 2]
    Y = y if one_output else np.column_stack([y, X[:, 0]])
    return poolreps.Forest(trees=7, n_min=15, seed=seed + 3).fit(X, Y), X


@pytest.mark.parametrize("one_output", [True, False])
def test_forest_pickles_bit_identically(one_output):
    f, X = fitted_forest(1, one_output)
    Q = np.random.default_rng(9).uniform(-1.5, 1.5, (300, 3))
    for g in roundtrips(f):
        assert np.array_equal(f.predict(Q), g.predict(Q))
        assert np.array_equal(f.apply(Q), g.apply(Q))
        assert np.array_equal(f.leaf_offsets, g.leaf_offsets)
        assert g.get_params() == f.get_params()
    unfitted = pickle.loads(pickle.dumps(poolreps.Forest(trees=3)))
    with pytest.raises(ValueError, match="call fit"):
        unfitted.predict(Q)
    assert repr(unfitted) == "Forest('forest.trees=3')"
    assert repr(f).startswith("Forest('forest.trees=7', 'forest.n_min=15', "
                              "'experiment.seed=4') fitted: 7 trees, ")


def test_policy_pickles_bit_identically():
    rng = np.random.default_rng(5)
    S, A, w = rng.uniform(size=(300, 2)), rng.normal(size=(300, 2)), rng.uniform(size=300)
    p = poolreps.Policy(n_min=40, seed=2).fit(S, A, w)
    Q = rng.uniform(size=(50, 2))
    for q in roundtrips(p):
        assert all(np.array_equal(x, y) for x, y in zip(p.mean_cov(Q, status=True),
                                                        q.mean_cov(Q, status=True)))
        assert np.array_equal(p.sample(Q, 3, n=4), q.sample(Q, 3, n=4))
        assert np.array_equal(p.log_prob(Q, A[:50]), q.log_prob(Q, A[:50]))
    assert repr(p) == "Policy('policy.n_min=40', 'experiment.seed=2') fitted: 300 samples, " \
                      "2 state, 2 action dimensions"


def test_an_incompatible_pickle_names_both_versions():
    f, _ = fitted_forest()
    st = f.__getstate__()
    with pytest.raises(ValueError, match="pickle format version 2, this poolreps reads version 1"):
        poolreps.Forest().__setstate__({**st, "format": 2})
    text = st["fit"]["text"].replace(b"poolreps-forest 1\n", b"poolreps-forest 2\n", 1)
    with pytest.raises(ValueError, match="forest format version 2, this library reads version 1"):
        pickle.loads(pickle.dumps(f).replace(st["fit"]["text"], text))
    with pytest.raises(ValueError, match="pickle format version None"):
        poolreps.Policy().__setstate__({"sets": ()})
    with pytest.raises(ValueError, match="PocketEnv: pickle format version 3"):
        poolreps.PocketEnv().__setstate__({"format": 3})


def test_a_c_object_alone_does_not_pickle_and_never_prints_on_delete():
    p = run_python("""
        import pickle, poolreps
        from poolreps._lib import Handle
        h = Handle.__new__(Handle)   # never initialised: owns nothing
        del h
        f = poolreps.Forest(trees=2).fit([[0.0], [1.0], [2.0]], [0.0, 1.0, 2.0])
        try:
            pickle.dumps(f._h)
        except TypeError as e:
            print("TypeError", "cannot be pickled by itself" in str(e))
        print(pickle.loads(pickle.dumps(f)).predict([[1.0]]))
    """)
    assert p.returncode == 0, p.stderr
    assert p.stderr == ""
    assert p.stdout.split()[:2] == ["TypeError", "True"]


# ---- the forest file format: C, CLI and Python ---------------------------------

def write_csv(path, header, rows):
    np.savetxt(path, np.asarray(rows, dtype=float), fmt="%.17g", delimiter=",",
               header=",".join(header), comments="")


def test_cli_save_load_and_python_agree(tmp_path):
    rng = np.random.default_rng(3)
    X = rng.uniform(-1, 1, (250, 2))
    y = X[:, 0] ** 2 - X[:, 1]
    write_csv(tmp_path / "tr.csv", ["u", "v", "ret"], np.column_stack([X, y]))
    Q = rng.uniform(-1, 1, (40, 2))
    write_csv(tmp_path / "te.csv", ["v", "u"], Q[:, ::-1])
    args = ["forest", "--train", tmp_path / "tr.csv", "--test", tmp_path / "te.csv",
            "--target", "ret", "--set", "forest.trees=6", "--seed", "5", "-q"]
    p = run_poolreps(args + ["--save", tmp_path / "f.txt", "-o", tmp_path / "p1.csv",
                             "--leaves", tmp_path / "l1.csv"])
    assert p.returncode == 0, p.stderr
    p = run_poolreps(["forest", "--load", tmp_path / "f.txt", "--test", tmp_path / "te.csv",
                      "-o", tmp_path / "p2.csv", "--leaves", tmp_path / "l2.csv"])
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "p1.csv").read_bytes() == (tmp_path / "p2.csv").read_bytes()
    assert (tmp_path / "l1.csv").read_bytes() == (tmp_path / "l2.csv").read_bytes()
    saved = (tmp_path / "f.txt").read_bytes()
    assert saved.startswith(b"poolreps-forest 1\n")
    assert b"\ninput u\ninput v\noutput ret\n" in saved
    # Python fits the same forest and writes the same text, but for the names
    f = poolreps.Forest(trees=6, seed=5).fit(X, y)
    assert f.save_text() == saved.replace(b"input u\ninput v\noutput ret",
                                          b"input x0\ninput x1\noutput y0")
    g = poolreps.Forest.from_text(saved, one_output=True)
    assert np.array_equal(g.predict(Q), f.predict(Q))
    pred = np.loadtxt(tmp_path / "p2.csv", delimiter=",", skiprows=1)
    assert np.array_equal(pred, f.predict(Q))  # the CLI writes round-trip decimals


@pytest.mark.parametrize("edit, code, msg", [
    (lambda t: t.replace(b"poolreps-forest 1", b"poolreps-forest 9"), 1,
     "forest format version 9, this library reads version 1"),
    (lambda t: b"hello\n" + t, 2, ":1: not a poolreps forest file"),
    (lambda t: t[:len(t) // 2], 2, ""),
    (lambda t: t.replace(b"split 0", b"split 7", 1), 2, "7 out of range 0..2"),
    (lambda t: t.replace(b"\nend\n", b"\nend\nmore\n"), 2, "text after 'end'"),
    (lambda t: t.replace(b"leaves", b"leafs"), 2, ":2: expected ' leaves'"),
])
def test_cli_load_refuses_a_bad_file_with_one_line(tmp_path, edit, code, msg):
    f, X = fitted_forest(2)
    (tmp_path / "f.txt").write_bytes(edit(f.save_text()))
    write_csv(tmp_path / "te.csv", ["x0", "x1", "x2"], X[:5])
    p = run_poolreps(["forest", "--load", tmp_path / "f.txt", "--test", tmp_path / "te.csv",
                      "-o", tmp_path / "out.csv"])
    lines = p.stderr.decode().splitlines()
    assert p.returncode == code and len(lines) == 1 and msg in lines[0], p.stderr
    assert lines[0].startswith(f"poolreps: {tmp_path / 'f.txt'}")
    assert not (tmp_path / "out.csv").exists()
    with pytest.raises((ValueError, OSError), match=msg or "forest"):
        poolreps.Forest.from_text(edit(f.save_text()))


def test_a_duplicated_sample_in_a_file_is_refused():
    f, _ = fitted_forest(4)
    lines = f.save_text().split(b"\n")
    i = next(k for k, ln in enumerate(lines) if ln.startswith(b"leaf ") and
             len(ln.split()) > 4)
    w = lines[i].split()
    w[-1] = w[-2]  # the same sample twice in one leaf
    lines[i] = b" ".join(w)
    with pytest.raises(OSError, match="a sample appears twice"):
        poolreps.Forest.from_text(b"\n".join(lines))


def test_load_refuses_save_options(tmp_path):
    p = run_poolreps(["forest", "--load", tmp_path / "f.txt", "--train", tmp_path / "x.csv",
                      "--test", tmp_path / "x.csv"])
    assert p.returncode == 1
    assert "--load takes no --train" in p.stderr.decode()


# ---- Ctrl-C in long calls ------------------------------------------------------

@pytest.mark.native
@pytest.mark.parametrize("call", [
    "poolreps.shoot(balls, actions)",
    "env.step_batch(balls, actions)",
    # 4 M rows took 0.46 s on a fast machine, less than the 0.5 s before the
    # signal
    "env.reset_batch(4 * n)",
    "forest.predict(np.zeros((16000000, 2)))",
    # the whole 4 M rows: 400 000 took only 0.37 s on an idle machine, less
    # than the 0.5 s before the signal
    "policy.mean_cov(balls[:, 2:4])",
    # one library call each (a fit, a solve): run in a worker thread that
    # the library's interrupt flag stops (13 s and 1.6 s on a busy machine);
    # REPS polls it once per iteration, which at 300 000 x 60 takes up to
    # 0.3 CPU s: 0.5 s for these
    ("poolreps.Forest(trees=50).fit(X, X[:, 0] + rng.normal(size=len(X)))", 0.5),
    ("poolreps.reps(rng.normal(size=len(F)), F)", 0.5),
])
def test_keyboard_interrupt_within_0_2_s(call):
    call, limit = call if isinstance(call, tuple) else (call, 0.2)
    p = run_python(f"""
        import os, signal, threading, time
        import numpy as np, poolreps
        n = 4000000
        env = poolreps.PocketEnv()
        balls, _ = env.reset_batch(n, seed=1)
        actions = np.full((n, 2), 0.3)
        rng = np.random.default_rng(0)
        S = rng.uniform(size=(300, 2))
        forest = poolreps.Forest(trees=5).fit(S, S[:, 0])
        policy = poolreps.Policy(n_min=40).fit(S, rng.normal(size=(300, 2)), None)
        X = rng.uniform(size=(400000, 4))
        F = rng.normal(size=(300000, 60))
        sent = []
        def interrupt():
            time.sleep(0.5)
            sent.append((time.perf_counter(), time.process_time()))
            os.kill(os.getpid(), signal.SIGINT)
        threading.Thread(target=interrupt).start()
        t0 = time.perf_counter()
        try:
            {call}
            print("finished", time.perf_counter() - t0)
        except KeyboardInterrupt:
            print("interrupted", time.perf_counter() - sent[0][0], time.process_time() - sent[0][1])
    """, timeout=300)
    assert p.returncode == 0, p.stderr
    word, *secs = p.stdout.split()
    assert word == "interrupted", f"the call ended after {secs[0]} s before the signal"
    wall, cpu = map(float, secs)
    # the work done between the signal and the exception: the process's CPU
    # time, which other load on the machine does not stretch
    assert cpu < limit, f"KeyboardInterrupt after {cpu} CPU s of work past SIGINT"
    # and the wall time, unless the process was kept off the CPU in that
    # window (less than 2/3 of it running: the machine is busy)
    if cpu >= wall / 1.5:
        assert wall < limit, f"KeyboardInterrupt {wall} s after SIGINT"


@pytest.mark.native
def test_no_interrupted_call_is_left_in_the_library_at_exit():
    """A script ended by Ctrl-C exits while the interrupted REPS solve
    finishes its iteration in a worker thread; the exit handlers of the
    libraries then freed what that worker was using (a segfault, about one
    exit in ten). The package waits for such workers at exit: by the last
    exit handler (registered before the import, so run after the
    package's), every one has ended."""
    p = run_python("""
        import atexit, os, signal, threading, time
        def check():
            left = poolreps._lib._STOPPING
            print("left", sum(not e.is_set() for e in left))
        atexit.register(check)
        import numpy as np, poolreps
        rng = np.random.default_rng(0)
        F = rng.normal(size=(300000, 60))
        def interrupt():
            time.sleep(0.5)
            os.kill(os.getpid(), signal.SIGINT)
        threading.Thread(target=interrupt).start()
        try:
            poolreps.reps(rng.normal(size=len(F)), F)
        except KeyboardInterrupt:
            print("interrupted")
    """, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["interrupted", "left", "0"], p.stdout


def test_chunked_calls_equal_one_call():
    # the pieces of a long batch give what one library call gives
    env = poolreps.PocketEnv()
    n = poolreps._lib.CHUNK_ROWS * 2 + 17
    S, _ = env.reset_batch(n, seed=8)
    A = np.random.default_rng(8).normal(0, 0.3, (n, 2))
    r = poolreps.shoot(S, A)
    one = poolreps.core.shoot_rows.__globals__["lib"]
    out = np.empty(n)
    import ctypes
    err = ctypes.create_string_buffer(512)
    cfg = poolreps._lib.config(poolreps._lib.assignments({"sim.mode": "event"}))
    final, pocket = np.empty((n, 2, 2)), np.empty((n, 2), dtype=np.intc)
    hit, gap, t, ev = (np.empty(n, dtype=np.bool_), np.empty(n), np.empty(n),
                       np.empty(n, dtype=poolreps._lib.C_LONG))
    assert one.pr_bind_shoot(cfg.ptr, n, 2, S.ctypes.data, A.ctypes.data, final.ctypes.data,
                             pocket.ctypes.data, hit.ctypes.data, gap.ctypes.data,
                             out.ctypes.data, t.ctypes.data, ev.ctypes.data, err) == 0
    assert np.array_equal(r["reward"], out) and np.array_equal(r["final"], final)
    # a bad row deep in the batch is named by its row in the whole batch
    S[n - 3, 2] = 99.0
    with pytest.raises(ValueError, match=f"row {n - 3}: "):
        poolreps.shoot(S, A)
    # Policy.sample in pieces draws what `poolreps policy --sample` draws: one stream
    rng = np.random.default_rng(1)
    X = rng.uniform(size=(300, 2))
    p = poolreps.Policy(n_min=40).fit(X, rng.normal(size=(300, 2)), None)
    Q = rng.uniform(size=(3000, 2))
    whole = p.sample(Q, 5)
    poolreps.core.POLICY_CHUNK, keep = 10**7, poolreps.core.POLICY_CHUNK
    try:
        assert np.array_equal(p.sample(Q, 5), whole)
    finally:
        poolreps.core.POLICY_CHUNK = keep


# ---- random streams ------------------------------------------------------------

def test_repetition_option_reproduces_experiment_3s_start_states(tmp_path):
    p = run_poolreps([ROOT / "data/exp3.ini", "-q", "-o", tmp_path / "e3", "--seed", "4",
                      "--set", "exp3.iterations=2", "--set", "experiment.repetitions=2",
                      "--set", "exp3.policies=handcrafted"])
    assert p.returncode == 0, p.stderr
    import csv
    rows = list(csv.DictReader(open(tmp_path / "e3/exp3_episodes.csv")))
    for k in (0, 1):
        want = np.array([[float(r[c]) for c in ("x0", "y0", "x1", "y1")] for r in rows
                         if r["repetition"] == str(k)])
        assert len(want) == 240
        env = poolreps.PocketEnv()
        first, _ = env.reset(seed=4, options={"repetition": k})
        got = np.vstack([first] + [env.reset()[0] for _ in range(len(want) - 1)])
        assert np.array_equal(got, want)
        assert np.array_equal(poolreps.PocketEnv().reset_batch(240, seed=4, repetition=k)[0],
                              want)
    # a plain seed is another stream
    assert not np.array_equal(poolreps.PocketEnv().reset_batch(240, seed=4)[0], want)


@needs_gym
def test_np_random_seeds_the_start_states_when_reset_has_no_seed():
    a, b = poolreps.PocketEnv(), poolreps.PocketEnv()
    a.np_random, _ = gymnasium.utils.seeding.np_random(12)
    b.np_random, _ = gymnasium.utils.seeding.np_random(12)
    assert np.array_equal(a.reset()[0], b.reset()[0])
    assert np.array_equal(a.reset()[0], b.reset()[0])
    c = poolreps.PocketEnv()
    c.np_random, _ = gymnasium.utils.seeding.np_random(13)
    assert not np.array_equal(c.reset()[0], a.reset()[0])


@pytest.mark.parametrize("seed", [1.5, True, -1, 2**32, "3"])
def test_policy_sample_refuses_a_seed_that_is_not_an_integer(seed):
    rng = np.random.default_rng(1)
    p = poolreps.Policy(n_min=40).fit(rng.uniform(size=(100, 2)), rng.normal(size=(100, 2)),
                                      None)
    with pytest.raises(ValueError, match="seed: must be an integer"):
        p.sample([[0.5, 0.5]], seed)
    with pytest.raises(ValueError, match="n: must be an integer"):
        p.sample([[0.5, 0.5]], 1, n=2.5)


def test_type_hints_ship_with_the_package():
    assert (ROOT / "python/poolreps/py.typed").exists()
    import typing
    hints = typing.get_type_hints(poolreps.shoot)
    assert "balls" in hints and "return" in hints


@needs_gym
def test_the_autoreset_example_of_docs_python_md():
    text = (ROOT / "docs/python.md").read_text()
    code = text.split("```python autoreset\n")[1].split("```")[0]
    ns = {}
    exec(compile(code.replace("print(", "mean = ("), "docs/python.md", "exec"), ns)
    rewards = np.array(ns["rewards"])
    assert rewards.shape == (10, 8) and (rewards != 0).all()  # every step is a shot
    # the default mode pads every other step with reward 0 (the best reward)
    envs = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=8, vectorization_mode="sync")
    envs.reset(seed=1)
    r = np.array([envs.step(np.random.default_rng(t).normal(0, 0.1, (8, 2)))[1]
                  for t in range(10)])
    assert (r[1::2] == 0).all() and (r[0::2] != 0).all()


# ---- the native vector env (poolreps.vector) ------------------------------------

def sync_same_step(n, **kwargs):
    from gymnasium.vector import AutoresetMode
    return gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=n, vectorization_mode="sync",
                              vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}, **kwargs)


@needs_gym
@pytest.mark.parametrize("kwargs", [{}, {"normalize_actions": True},
                                    {"set": {"table.friction": 0.4, "table.balls": 3}},
                                    {"randomize": {"table.friction": (0.1, 0.6),
                                                   "table.restitution": (0.3, 1.0)}}])
def test_native_vector_env_equals_sync_vector_env(kwargs):
    from poolreps.vector import PocketVectorEnv
    n = 7
    native = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=n,
                                vectorization_mode="vector_entry_point", **kwargs)
    assert isinstance(native, PocketVectorEnv)
    assert native.metadata["autoreset_mode"].value == "SameStep"
    sync = sync_same_step(n, **kwargs)
    assert native.observation_space == sync.observation_space
    assert native.action_space == sync.action_space
    a, ia = native.reset(seed=11)
    b, ib = sync.reset(seed=11)
    assert np.array_equal(a, b) and set(ia) == set(ib)
    assert all(np.array_equal(ia[k], ib[k]) for k in ia)
    rng = np.random.default_rng(5)
    for step in range(6):
        act = native.action_space.sample() if step % 2 else rng.normal(0, 0.3, (n, 2))
        act = act.astype(native.action_space.dtype)
        o1, r1, t1, u1, i1 = native.step(act)
        o2, r2, t2, u2, i2 = sync.step(act)
        assert np.array_equal(r1, r2) and np.array_equal(o1, o2)
        assert t1.all() and t2.all() and not u1.any() and not u2.any()
        assert np.array_equal(i1["final_obs"], np.stack(i2["final_obs"]))
        assert i1["_final_obs"].all()
        assert set(i1) == set(i2) and set(i1["final_info"]) == set(i2["final_info"])
        assert all(np.array_equal(i1[k], i2[k]) for k in i1 if k[0] != "f")
        for k, v in i2["final_info"].items():
            assert np.array_equal(i1["final_info"][k], v.astype(i1["final_info"][k].dtype)), k
    # a list of seeds: one per sub-env
    seeds = [3, 2**32 - 1, 0, 9, 4, 4, 17]
    a, _ = native.reset(seed=seeds)
    assert np.array_equal(a, np.stack([poolreps.PocketEnv(**kwargs).reset(seed=s)[0]
                                       for s in seeds]))


def stepped_alike(ref, envs, rng, n, steps=3):
    """Steps ref and each of envs (n sub-envs) with the same random
    actions; yields (ref's step, env's step) once their observations and
    rewards are found to be the same bytes."""
    for _ in range(steps):
        act = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
        want = ref.step(act)
        for e in envs:
            got = e.step(act)
            for k in (0, 1):
                assert got[k].tobytes() == want[k].tobytes()
            yield want, got


@needs_gym
def test_native_vector_env_threads_change_no_number():
    """200 sub-envs, their shots split over 1, 3 or one thread per CPU (the
    default): the same bytes as SyncVectorEnv's, randomized physics too."""
    kw = {"normalize_actions": True, "randomize": {"table.friction": (0.1, 0.6)}}
    n = 200
    envs = [gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=n, threads=t,
                               vectorization_mode="vector_entry_point", **kw) for t in (1, 3, 0)]
    assert [e.threads for e in envs] == [1, 3, 0]
    sync = sync_same_step(n, **kw)
    for e in envs + [sync]:
        e.reset(seed=21)
    for want, got in stepped_alike(sync, envs, np.random.default_rng(3), n):
        assert got[4]["final_obs"].tobytes() == np.stack(want[4]["final_obs"]).tobytes()
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="threads"):
            poolreps.vector.PocketVectorEnv(num_envs=2, threads=bad)


@needs_gym
def test_native_vector_env_pickles_mid_run_and_continues_bit_identically():
    """As a SyncVectorEnv of PocketEnvs pickles: the copies (threads kept)
    step on from the pending start states with the same numbers."""
    from poolreps.vector import PocketVectorEnv
    n = 70
    env = PocketVectorEnv(num_envs=n, threads=3, normalize_actions=True,
                          randomize={"table.friction": (0.1, 0.6)})
    env.reset(seed=8)
    rng = np.random.default_rng(5)
    env.step(rng.uniform(-1, 1, (n, 2)).astype(np.float32))
    twins = roundtrips(env)
    assert [t.threads for t in twins] == [3, 3, 3] and repr(twins[0]) == repr(env)
    for want, got in stepped_alike(env, twins, rng, n):
        assert got[4]["table.friction"].tobytes() == want[4]["table.friction"].tobytes()
    fresh = pickle.loads(pickle.dumps(PocketVectorEnv(num_envs=2)))
    with pytest.raises(RuntimeError, match="reset"):
        fresh.step(np.zeros((2, 2)))


@needs_gym
def test_native_vector_env_refuses_bad_input_and_changes_nothing():
    venv = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=3)
    with pytest.raises(RuntimeError, match="reset"):
        venv.step(np.zeros((3, 2)))
    first, _ = venv.reset(seed=1)
    for bad in ({"stat": 1}, {"set": {"table.friction": 0.3}}, {"state": np.zeros((2, 4))},
                {"state": np.zeros((3, 4))}):
        with pytest.raises(ValueError):
            venv.reset(seed=99, options=bad)
    for seed in (-1, 1.5, [1, 2], True):
        with pytest.raises(ValueError, match="seed"):
            venv.reset(seed=seed)
    # nothing was reseeded by the failed calls: the streams continue
    ref = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=3)
    ref.reset(seed=1)
    assert np.array_equal(venv.reset()[0], ref.reset()[0])
    with pytest.raises(ValueError, match="actions"):
        venv.step(np.zeros((2, 2)))
    given = np.array([[-0.25, 0, 0.1, 0.05]] * 3)
    assert np.array_equal(venv.reset(options={"state": given})[0], given)
    with pytest.raises(ValueError, match="num_envs"):
        poolreps.vector.PocketVectorEnv(num_envs=0)


@needs_gym
@pytest.mark.parametrize("mode", ["sync", "vector_entry_point"])
def test_any_seed_gymnasium_accepts_works_for_vector_envs(mode):
    venv = gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=4, vectorization_mode=mode)
    obs, _ = venv.reset(seed=2**32 - 2)
    # sub-env i is seeded with seed + i, wrapped to 0..2**32-1
    want = [poolreps.PocketEnv().reset(seed=s)[0] for s in (2**32 - 2, 2**32 - 1, 0, 1)]
    assert np.array_equal(obs, np.stack(want))
    big = 2**70 + 5
    env = poolreps.PocketEnv()
    assert np.array_equal(env.reset(seed=big)[0], poolreps.PocketEnv().reset(seed=5)[0])
    assert env.np_random_seed == big  # np_random is Gymnasium's, from the full seed


@needs_gym
def test_reset_refuses_unknown_options_and_changes_nothing():
    env = poolreps.PocketEnv()
    env.reset(seed=3)
    before = env.np_random.bit_generator.state
    for bad in ({"stat": [0, 0, 0.1, 0]}, {"set": {"table.friction": 0.3}}):
        with pytest.raises(ValueError, match="options: unknown key"):
            env.reset(seed=8, options=bad)
    assert env.np_random.bit_generator.state == before
    ref = poolreps.PocketEnv()
    ref.reset(seed=3)
    assert np.array_equal(env.reset()[0], ref.reset()[0])


# ---- domain randomisation (PocketEnv(randomize=...)) ----------------------------

RANDOMIZE = {"table.friction": (0.1, 0.6), "table.restitution": (0.3, 1.0),
             "reward.miss_penalty": (0.5, 2.0)}


def test_randomize_draws_per_episode_and_shoots_with_the_values():
    env = poolreps.PocketEnv(randomize=RANDOMIZE)
    seen = []
    obs, info = env.reset(seed=21)
    for episode in range(8):
        assert set(info) == set(RANDOMIZE)
        for k, (lo, hi) in RANDOMIZE.items():
            assert lo <= info[k] < hi
        a = np.array([0.3 - 0.05 * episode, 0.1])
        final, reward, _, _, step_info = env.step(a)
        # the oracle: one shot with the episode's values as plain keys
        ref = poolreps.shoot(obs[None], a[None], set={"experiment.name": "exp3", **info})
        assert reward == ref["reward"][0] and np.array_equal(final, ref["final"].reshape(-1))
        assert all(step_info[k] == info[k] for k in RANDOMIZE)
        traj = env.trajectory()
        for b in range(env.n_balls):  # the trajectory is the randomized shot's
            last = traj[traj[:, 3] == b][-1]
            if ref["pocket"][0, b] < 0:
                assert np.allclose(last[1:3], final[2 * b:2 * b + 2])
        seen.append(tuple(info.values()))
        obs, info = env.reset()
    assert len(set(seen)) == len(seen)
    # the same seed draws the same episodes; pickling continues the stream
    again = poolreps.PocketEnv(randomize=RANDOMIZE)
    assert tuple(again.reset(seed=21)[1].values()) == seen[0]
    clone = pickle.loads(pickle.dumps(again))
    assert clone.reset()[1] == again.reset()[1]


def test_randomize_batch_calls_and_refusals():
    env = poolreps.PocketEnv(randomize=RANDOMIZE)
    states, info = env.reset_batch(30, seed=4)
    assert set(info) == set(RANDOMIZE) and all(v.shape == (30,) for v in info.values())
    acts = np.random.default_rng(0).normal(0, 0.3, (30, 2))
    _, rewards, _, _, _ = env.step_batch(states, acts, info)
    assert np.array_equal(rewards, poolreps.shoot(states, acts, set={"experiment.name": "exp3"},
                                                  params=info)["reward"])
    assert poolreps.PocketEnv().reset_batch(2, seed=4)[1] == {}
    for bad, msg in [({"table.frction": (0, 1)}, "unknown key"),
                     ({"table.balls": (2, 3)}, "not a number key"),
                     ({"forest.trees": (1, 2)}, "only table., sim. and reward."),
                     ({"table.friction": (-1, 0.5)}, "out of range"),
                     ({"table.friction": (0.5, 0.1)}, "low 0.5 > high 0.1"),
                     ({"table.friction": 0.3}, r"expected \(low, high\)"),
                     ({"table.friction": (0.1, np.nan)}, "not a finite")]:
        with pytest.raises(ValueError, match=msg):
            poolreps.PocketEnv(randomize=bad)


# ---- animated shots (rgb_array_list, human) ------------------------------------

def cue_pixel(renderer, x, y):
    c, r = renderer._px(x, y)
    return int(r), int(c)


@pytest.mark.parametrize("kw", [{}, {"randomize": {"table.friction": (0.3, 0.6)}}])
def test_rgb_array_list_animates_the_shot_with_the_simulators_positions(kw):
    env = poolreps.PocketEnv(render_mode="rgb_array_list", **kw)
    fps = env.metadata["render_fps"]
    assert fps >= 10
    obs, info = env.reset(seed=5)
    first = env.render()
    assert len(first) == 1 and env.render() == []  # frames are handed out once
    a = np.array([0.3, 0.05])  # a typical Experiment 3 shot
    final, *_ = env.step(a)
    frames = env.render()
    assert len(frames) >= 10
    assert all(f.shape == (200, 400, 3) and f.dtype == np.uint8 for f in frames)
    r = env._renderer
    # the oracle: the shot stopped at t = k / fps by sim.max_time (a --set key)
    for k in range(1, len(frames) - 1, max(1, (len(frames) - 2) // 7)):
        ref = poolreps.shoot(obs[None], a[None], set={"experiment.name": "exp3", **info,
                                                      "sim.max_time": k / fps})
        x, y = ref["final"][0, 0]
        assert tuple(frames[k][cue_pixel(r, x, y)]) == (245, 245, 245), k
    assert np.array_equal(frames[-1], poolreps.PocketEnv(render_mode="rgb_array", **kw)
                          ._get_renderer().frame(final, env.trajectory()))
    # the trail grows frame by frame
    trail = [int((f != frames[0]).any(axis=2).sum()) for f in frames[1:]]
    assert trail[-1] > trail[0]
    # reset starts a new list
    env.reset()
    assert len(env.render()) == 1


@needs_gym
def test_rgb_array_list_through_gymnasium_make_and_human_plays_the_shot(monkeypatch):
    env = gymnasium.make("poolreps/PocketEnv-v0", render_mode="rgb_array_list")
    assert env.unwrapped.render_mode == "rgb_array_list"  # native: no RenderCollection
    env.reset(seed=2)
    env.step(np.array([0.3, 0.05]))
    frames = env.render()
    assert len(frames) >= 12 and frames[0].shape == (200, 400, 3)
    from gymnasium.utils.env_checker import check_env
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # Gymnasium's checker passes without a warning
        check_env(gymnasium.make("poolreps/PocketEnv-v0", normalize_actions=True,
                                 render_mode="rgb_array_list").unwrapped)
    from poolreps import render
    shown = []
    monkeypatch.setattr(render.Renderer, "show", lambda self, f, pause=0: shown.append(pause))
    human = poolreps.PocketEnv(render_mode="human")
    human.reset(seed=2)
    human.step(np.array([0.3, 0.05]))
    assert len(shown) == len(frames)  # the start frame, then the shot's frames
    assert shown[-1] == pytest.approx(1 / human.metadata["render_fps"])


def _shot_frames(seed, action):
    """The frames a PocketEnv renders for one episode: after reset, then
    after the shot."""
    env = poolreps.PocketEnv(render_mode="rgb_array_list")
    env.reset(seed=seed)
    frames = env.render()
    env.step(action)
    return frames + env.render(), env.metadata["render_fps"]


def _recorded_episode(folder, seed, action):
    from poolreps.video import RecordVideo
    env = gymnasium.make("poolreps/PocketEnv-v0", render_mode="rgb_array_list")
    rec = RecordVideo(env, str(folder), episode_trigger=lambda e: True, disable_logger=True)
    rec.reset(seed=seed)
    rec.step(action)
    rec.close()


@needs_gym
def test_record_video_writes_every_frame_of_the_shot(tmp_path, monkeypatch):
    """poolreps.video.RecordVideo hands MoviePy every frame of the episode
    (Gymnasium's keeps the last of each render's list), at render_fps; with
    MoviePy installed, the clip written has as many frames as MoviePy
    writes from those frames itself (its writer drops a last frame or two
    to rounding)."""
    import types
    action = np.array([0.3, 0.05])
    want, fps = _shot_frames(2, action)
    assert len(want) >= 12
    try:
        from moviepy import ImageSequenceClip, VideoFileClip
    except ImportError:
        VideoFileClip = None
    if VideoFileClip is not None:
        _recorded_episode(tmp_path / "real", 2, action)
        ImageSequenceClip(want, fps=fps).write_videofile(str(tmp_path / "ref.mp4"), logger=None)
        counts = []
        for path in (tmp_path / "real" / "rl-video-episode-0.mp4", tmp_path / "ref.mp4"):
            clip = VideoFileClip(str(path))
            assert clip.fps == fps
            counts.append(sum(1 for _ in clip.iter_frames()))
            clip.close()
        assert counts[0] == counts[1] > len(want) - 3
    got = []

    class Clip:  # MoviePy's ImageSequenceClip as Gymnasium calls it
        def __init__(self, frames, fps):
            got.append((list(frames), fps))

        def write_videofile(self, path, logger=None):
            open(path, "wb").close()
    mod = types.ModuleType("moviepy.video.io.ImageSequenceClip")
    mod.ImageSequenceClip = Clip
    for name in ("moviepy", "moviepy.video", "moviepy.video.io"):
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    _recorded_episode(tmp_path / "fake", 2, action)
    [(frames, rate)] = got
    assert rate == fps and len(frames) == len(want)
    assert all(np.array_equal(a, b) for a, b in zip(frames, want))


# ---- typing ----------------------------------------------------------------------

USER_SCRIPT = '''
import gymnasium as gym
import numpy as np
import numpy.typing as npt
import poolreps

env = gym.make("poolreps/PocketEnv-v0", normalize_actions=True)
n: int = gym.spaces.flatdim(env.action_space)
pe = poolreps.PocketEnv(normalize_actions=True, randomize={"table.friction": (0.2, 0.3)})
m: int = gym.spaces.flatdim(pe.action_space) + gym.spaces.flatdim(pe.observation_space)
box: gym.spaces.Box = pe.observation_space
obs, info = pe.reset(seed=1)
o2: npt.NDArray[np.float64] = obs
states, binfo = pe.reset_batch(8, seed=2)
final, rewards, term, trunc, sinfo = pe.step_batch(states, np.zeros((8, 2)), binfo)
r: npt.NDArray[np.float64] = rewards + final.sum(axis=1)
t: npt.NDArray[np.bool_] = term | trunc
res = poolreps.shoot(states, np.zeros((8, 2)), params={"table.friction": 0.3})
g: npt.NDArray[np.float64] = res["reward"]
venv = gym.make_vec("poolreps/PocketEnv-v0", num_envs=4)
vobs, vinfo = venv.reset(seed=3)
frames = poolreps.PocketEnv(render_mode="rgb_array_list").render()
'''


@needs_gym
def test_a_user_script_passes_mypy_strict(tmp_path):
    """The package as a user sees it (installed, typed: py.typed): its own
    modules are followed silently, the user's script is checked strictly."""
    pytest.importorskip("mypy", reason="mypy is not installed (build/venv/bin/pip install mypy)")
    (tmp_path / "user.py").write_text(USER_SCRIPT)
    env = child_env()
    env["MYPYPATH"] = env.pop("PYTHONPATH")
    r = run_cmd([sys.executable, "-m", "mypy", "--strict", "--follow-imports=silent",
                 "--no-incremental", "--cache-dir", str(tmp_path / "cache"), "user.py"],
                capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_vector_bench_block_of_docs_python_md():
    """docs/python.md's numbers are what scripts/bench_vector_table.py
    makes of the committed docs/bench_vector.csv."""
    p = run_cmd([sys.executable, str(ROOT / "scripts" / "bench_vector_table.py"), "--check"],
                capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
