"""The Python API is as strict as the CLI: every refusal of `poolreps
forest`, `policy` and `reps` on values (weights, targets), keys of another
section and options that do not apply is also a ValueError (or its
NumericalError) of the binding, with the same message after the part that
says where the value came from (a CSV file and column for the CLI, an
argument for Python). Each case runs both and compares; the CLI's run also
checks that nothing was written."""
import os
import sys

import numpy as np
import pytest

from conftest import ROOT
from test_safety import NUM, USAGE, SAN, changed, one_line, run, snapshot

sys.path.insert(0, str(ROOT / "python"))

if SAN and "libasan" not in os.environ.get("LD_PRELOAD", ""):
    pytest.skip("the sanitized library loads only with its runtimes preloaded", allow_module_level=True)

import poolreps  # noqa: E402

N = 40
S0 = np.arange(N) * 0.01
S1 = (np.arange(N) % 7) * 0.1
A0 = (np.arange(N) % 5) * 0.1


def csv(cols):
    names = list(cols)
    rows = zip(*(cols[k] for k in names))
    return (",".join(names) + "\n" + "".join(",".join(repr(float(v)) for v in r) + "\n"
                                             for r in rows)).encode()


def weights(kind):
    w = np.ones(N)
    if kind == "huge":
        w[:] = 1e308
    elif kind == "negative":
        w[3] = -1.0
    elif kind == "zero":
        w[:] = 0.0
    return w


def forest_weights(kind):
    w = weights(kind)
    return (["forest", "--train", "t.csv", "--test", "t.csv", "--target", "y", "--weight", "w"],
            csv({"s0": S0, "s1": S1, "y": A0, "w": w}),
            lambda: poolreps.Forest().fit(np.c_[S0, S1], A0, sample_weight=w))


def policy_weights(kind):
    w = weights(kind)
    return (["policy", "--train", "t.csv", "--state", "s0", "--action", "a0", "--weight", "w",
             "-i", "t.csv"], csv({"s0": S0, "a0": A0, "w": w}),
            lambda: poolreps.Policy().fit(S0[:, None], A0[:, None], w))


def reps_base(kind):
    q = weights(kind)
    return (["reps", "--return", "R", "--features", "phi", "--base", "q", "-i", "t.csv"],
            csv({"R": -A0, "phi": S1, "q": q}),
            lambda: poolreps.reps(-A0, S1, base=q))


def forest_huge_targets():
    y = np.full(N, 1e308)
    return (["forest", "--train", "t.csv", "--test", "t.csv", "--target", "y"],
            csv({"s0": S0, "s1": S1, "y": y}),
            lambda: poolreps.Forest().fit(np.c_[S0, S1], y).predict(np.c_[S0, S1]))


def other_section(cmd, key):
    base = {"forest": (["forest", "--train", "t.csv", "--test", "t.csv", "--target", "y"],
                       lambda: poolreps.Forest(**{key: 7})),
            "policy": (["policy", "--train", "t.csv", "--state", "s0", "--action", "y", "-i", "t.csv"],
                       lambda: poolreps.Policy(**{key: 7})),
            "reps": (["reps", "--return", "y", "--features", "s0", "-i", "t.csv"],
                     lambda: poolreps.reps(-A0, S1, set={key: 7}))}[cmd]
    return base[0] + ["--set", f"{key}=7"], csv({"s0": S0, "s1": S1, "y": A0}), base[1]


def policy_target():
    return (["policy", "--train", "t.csv", "--state", "s0", "--action", "a0", "--target", "y",
             "-i", "t.csv"], csv({"s0": S0, "a0": A0, "y": S1}),
            lambda: poolreps.Policy().fit(S0[:, None], A0[:, None], None, target=S1[:, None]))


CASES = [(f"forest_weights_{k}", lambda k=k: forest_weights(k), USAGE) for k in ("huge", "negative", "zero")]
CASES += [(f"policy_weights_{k}", lambda k=k: policy_weights(k), USAGE) for k in ("huge", "negative", "zero")]
CASES += [(f"reps_base_{k}", lambda k=k: reps_base(k), USAGE) for k in ("huge", "negative", "zero")]
CASES += [("forest_huge_targets", forest_huge_targets, NUM), ("policy_target_not_read", policy_target, USAGE)]
CASES += [(f"{c}_key_{k}", lambda c=c, k=k: other_section(c, k), USAGE)
          for c, k in (("forest", "policy.n_min"), ("forest", "reps.epsilon"), ("policy", "forest.trees"),
                       ("policy", "value.n_min"), ("reps", "forest.trees"), ("reps", "experiment.seed"))]


def what(msg):
    """The message without where the value came from: after "FILE[:LINE]:
    column 'C': " (CLI) or "NAME[i]: " (Python), '--' of an option dropped."""
    msg = msg.removeprefix("poolreps: ").rstrip("\n")
    if "column '" in msg:
        msg = msg.split("': ", 1)[1]
    elif msg.split(":")[0] in ("sample_weight", "w", "base") or msg.split("[")[0] in ("sample_weight", "w", "base"):
        msg = msg.split(": ", 1)[1]
    return msg.replace("--target", "target").replace("to write", "to return")


@pytest.mark.parametrize("make,code", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_python_refuses_what_the_cli_refuses(make, code, tmp_path):
    args, data, call = make()
    (tmp_path / "t.csv").write_bytes(data)
    before = snapshot(tmp_path)
    r = run(args + ["-q", "-o", "out.csv"], tmp_path)
    assert r.returncode == code, r.stderr
    cli = one_line(r)
    assert changed(before, snapshot(tmp_path)) == set()
    with pytest.raises(ValueError) as e:
        call()
    if code == NUM:
        assert isinstance(e.value, poolreps.NumericalError)
        cli = cli.split(": field 1: ")[1] if ": field 1: " in cli else cli
        py = str(e.value).split(": ", 2)[2]
        assert what(cli) == what(py), (cli, str(e.value))
    else:
        assert what(cli) == what(str(e.value)), (cli, str(e.value))


# ---- Ctrl-C reaches a Python caller at once, whatever a row costs ----

def interrupted_late(call):
    """Seconds from a SIGINT sent 0.5 s into call() to its KeyboardInterrupt."""
    import signal
    import threading
    import time
    sent = []

    def fire():
        time.sleep(0.5)
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)
    t = threading.Thread(target=fire)
    t.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
        return time.monotonic() - sent[0]
    finally:
        t.join()


@pytest.mark.parametrize("dt,rows,threads", [(1e-6, 400, 1), (2e-5, 20000, 1), (2e-5, 20000, 2)])
def test_ctrl_c_reaches_shoot_within_half_a_second(dt, rows, threads):
    """Stepped rows of about 0.08 s (dt = 1e-6) or 4 ms (2e-5) each: the
    whole call would take many seconds; SIGINT 0.5 s in must raise
    KeyboardInterrupt within 0.5 s, and the next call runs normally (on
    one thread or split over two)."""
    b = np.tile([-0.25, 0, 0.1, 0], (rows, 1))
    a = np.tile([0.615, 0.03], (rows, 1))
    late = interrupted_late(lambda: poolreps.shoot(b, a, mode="stepped", set={"sim.dt": dt},
                                                   threads=threads))
    assert late < 0.5, f"KeyboardInterrupt {late:.2f} s after SIGINT"
    r = poolreps.shoot(b[:200], a[:200], mode="stepped", set={"sim.dt": 1e-4}, threads=threads)
    assert np.isfinite(r["reward"]).all()


def chain_forest(depth, trees):
    """A forest whose trees are chains: a large x walks all depth splits of
    each (a row costs about a millisecond)."""
    lines = ["poolreps-forest 1", f"trees {trees} samples {depth + 1} inputs 1 outputs 1 "
             f"nodes {trees * (2 * depth + 1)} leaves {trees * (depth + 1)}", "input x0", "output y0"]
    for t in range(trees):
        lines.append(f"tree {t}")
        for i in range(depth):
            lines += [f"split 0 {float(i).hex()}", f"leaf 1 {float(i).hex()} {i}"]
        lines.append(f"leaf 1 {float(depth).hex()} {depth}")
    return poolreps.Forest.from_text(("\n".join(lines + ["end"]) + "\n").encode())


def test_ctrl_c_reaches_forest_and_policy_calls_within_half_a_second():
    """Forest.predict/apply of rows of about a millisecond, Policy.sample of
    20,000 draws per state (a few ms): calls of many seconds, in which a
    fixed piece of rows (8,192 or 1,024) takes seconds. SIGINT 0.5 s in must
    raise KeyboardInterrupt within 0.5 s; the next call gives the same
    numbers as before."""
    f = chain_forest(50000, 2)
    X = np.full((20000, 1), 1e9)
    assert np.array_equal(f.predict(X[:3]).ravel(), [50000.0] * 3)
    rng = np.random.default_rng(0)
    S = rng.normal(size=(300, 2))
    p = poolreps.Policy(n_min=40).fit(S, rng.normal(size=(300, 2)), None)
    Q = np.repeat(S, 7, axis=0)
    first = p.sample(Q[:5], 3, n=20000)
    for call in (lambda: f.predict(X), lambda: f.apply(X), lambda: p.sample(Q, 3, n=20000)):
        late = interrupted_late(call)
        assert late < 0.5, f"KeyboardInterrupt {late:.2f} s after SIGINT"
    assert np.array_equal(f.predict(X[:3]).ravel(), [50000.0] * 3)
    assert np.array_equal(p.sample(Q[:5], 3, n=20000), first)


# ---- PocketEnv on extreme actions, seeds and counts ----

@pytest.mark.parametrize("action,normalize", [([1.5e308, 1.5e308], False), ([-1e308, 1e307], False),
                                              ([1e308, -1e308], True), ([3.0, -4e300], True)])
def test_huge_action_keeps_its_direction(action, normalize):
    env = poolreps.PocketEnv(normalize_actions=normalize)
    env.reset(seed=3)
    _, _, _, _, info = env.step(action)
    v = info["velocity"]
    assert info["clipped"] and np.all(np.isfinite(v))
    assert 0.999 * env.max_speed < np.hypot(*v) <= env.max_speed
    a = np.array(action) / np.abs(action).max()
    assert np.allclose(v / np.hypot(*v), a / np.hypot(*a), rtol=1e-12, atol=1e-300)


def test_failed_reset_leaves_np_random_unchanged():
    pytest.importorskip("gymnasium")
    env = poolreps.PocketEnv()
    env.reset(seed=5)
    before = env.np_random.bit_generator.state
    for seed in (-1, 1.5):  # any seed >= 0 is wrapped to 0..2**32-1 (test_gym.py)
        with pytest.raises(ValueError, match="seed: must be an integer"):
            env.reset(seed=seed)
        assert env.np_random.bit_generator.state == before


@pytest.mark.parametrize("n", [2.9, -1, True, "3"])
def test_reset_batch_refuses_a_count_that_is_no_whole_number(n):
    env = poolreps.PocketEnv()
    with pytest.raises(ValueError, match="n: must be a whole number >= 0"):
        env.reset_batch(n)
