"""Per-row physics and reward parameters: poolreps.shoot(params=...) and
`poolreps shoot` with key columns against one call per row with set= /
--set (an oracle that shares only the simulator: the per-row path sets the
keys from numbers, the oracle through their text), on seeded random
problems; broadcasting; refusals that change nothing."""
import csv
import io
import sys

import numpy as np
import pytest

from conftest import ROOT, run_poolreps

sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402

# key -> range to draw from (inside every key's allowed range)
KEYS = {
    "table.friction": (0.05, 2.0),
    "table.restitution": (0.0, 1.0),
    "table.stop_speed": (1e-4, 0.05),
    "table.pocket_radius": (0.01, 0.03),  # no start ball inside a pocket
    "reward.miss_penalty": (0.0, 10.0),
    "reward.scratch_penalty": (0.0, 2.0),
    "table.length": (1.0, 3.0),       # validated per row (the ball on the table)
    "sim.max_time": (0.5, 100.0),
}


def problem(seed, n, nballs=2):
    env = poolreps.PocketEnv(set={"table.balls": nballs})
    states, _ = env.reset_batch(n, seed=seed)
    actions = np.random.default_rng(seed).normal(0, 0.4, (n, 2))
    return states, actions


def per_row(states, actions, params, mode="event", set=None):
    rows = []
    for i in range(states.shape[0]):
        keys = {**(set or {}), **{k: float(v[i]) for k, v in params.items()}}
        rows.append(poolreps.shoot(states[i:i + 1], actions[i:i + 1], mode=mode, set=keys))
    return {k: np.concatenate([r[k] for r in rows]) for k in rows[0]}


@pytest.mark.parametrize("seed", range(6))
def test_params_equal_one_call_per_row_with_set(seed):
    rng = np.random.default_rng(100 + seed)
    n = 40
    states, actions = problem(seed, n, nballs=2 + seed % 3)
    keys = rng.choice(sorted(KEYS), size=1 + seed % 4, replace=False)
    params = {k: rng.uniform(*KEYS[k], n) for k in keys}
    # heavy ties and extremes: repeated rows reuse the simulator
    params[keys[0]][::3] = KEYS[keys[0]][0]
    mode = "stepped" if seed == 5 else "event"
    got = poolreps.shoot(states, actions, mode=mode, params=params)
    want = per_row(states, actions, params, mode=mode)
    for k in want:
        assert np.array_equal(got[k], want[k]), (k, list(keys))


def test_scalars_broadcast_and_a_constant_equals_set():
    states, actions = problem(7, 50)
    a = poolreps.shoot(states, actions, params={"table.friction": 0.4})
    b = poolreps.shoot(states, actions, set={"table.friction": 0.4})
    c = poolreps.shoot(states, actions, params={"table.friction": np.full(50, 0.4)})
    for k in a:
        assert np.array_equal(a[k], b[k]) and np.array_equal(a[k], c[k])
    # params apply on top of set, row by row
    f = np.linspace(0.1, 1.0, 50)
    d = poolreps.shoot(states, actions, set={"table.restitution": 0.5},
                       params={"table.friction": f})
    e = per_row(states, actions, {"table.friction": f}, set={"table.restitution": 0.5})
    assert all(np.array_equal(d[k], e[k]) for k in d)
    assert not np.array_equal(a["t_end"], d["t_end"])  # the values do reach the simulator


@pytest.mark.parametrize("params, msg", [
    ({"table.frction": 0.3}, "table.frction: unknown key"),
    ({"table.balls": 3}, "table.balls: not a number key"),
    ({"table.friction_law": 1}, "not a number key"),
    ({"forest.trees": 3}, "only table., sim. and reward."),
    ({"table.friction": np.ones(3)}, "expected 5 rows"),
    ({"table.friction": np.ones((5, 1))}, "1-D"),
    ({"table.friction": [0.1, 0.2, -1, 0.3, 0.4]}, "row 2: table.friction: -1 out of range"),
    ({"table.friction": [0.1, 0.2, np.nan, 0.3, 0.4]}, "row 2: table.friction: not a finite"),
    ({"table.length": [2, 2, 2, 2, 0.05]}, "row 4: .*box reaches beyond the cushions"),
    ({"table.friction": "x"}, "real numbers"),
    ({3: 0.1}, "keys are 'section.key' strings"),
])
def test_bad_params_are_refused(params, msg):
    states, actions = problem(1, 5)
    with pytest.raises(ValueError, match=msg):
        poolreps.shoot(states, actions, params=params)


def read_csv(text):
    return list(csv.reader(io.StringIO(text)))


def test_cli_key_columns_equal_per_row_set():
    rng = np.random.default_rng(3)
    states, actions = problem(3, 12)
    f, k = rng.uniform(0.05, 1.0, 12), rng.uniform(0.2, 1.0, 12)
    head = "x0,y0,x1,y1,table.friction,vx,vy,table.restitution\n"
    body = "".join(f"{s[0]!r},{s[1]!r},{s[2]!r},{s[3]!r},{a!r},{v[0]!r},{v[1]!r},{b!r}\n"
                   for s, v, a, b in zip(states, actions, f, k))
    out = run_poolreps(["shoot"], input=(head + body).encode())
    assert out.returncode == 0, out.stderr
    rows = read_csv(out.stdout.decode())
    for i in range(12):
        one = "x0,y0,x1,y1,vx,vy\n" + ",".join(repr(float(x)) for x in
                                                 (*states[i], *actions[i])) + "\n"
        ref = run_poolreps(["shoot", "--set", f"table.friction={f[i]!r}", "--set",
                            f"table.restitution={k[i]!r}"], input=one.encode())
        assert read_csv(ref.stdout.decode())[1] == rows[i + 1]
    py = poolreps.shoot(states, actions, params={"table.friction": f, "table.restitution": k})
    assert [float(r[8]) for r in rows[1:]] == list(py["reward"])  # column reward


@pytest.mark.parametrize("col, value, msg", [
    ("table.frction", "0.3", "<stdin>:1: table.frction: unknown key"),
    ("table.friction", "-1", "<stdin>:3: table.friction: -1 out of range"),
    ("table.friction", "abc", "<stdin>:3: "),
    ("forest.trees", "3", "<stdin>:1: forest.trees: only table., sim. and reward."),
])
def test_cli_bad_key_columns_fail_and_write_nothing(tmp_path, col, value, msg):
    text = f"x0,y0,x1,y1,vx,vy,{col}\n-0.25,0,0.1,0.05,0.3,0.1,0.2\n" \
           f"-0.25,0,0.1,0.05,0.3,0.1,{value}\n"
    before = sorted(p.name for p in tmp_path.iterdir())
    out = run_poolreps(["shoot", "-o", tmp_path / "out.csv"], input=text.encode())
    assert out.returncode != 0
    err = out.stderr.decode()
    assert err.count("\n") == 1 and msg in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_key_columns_with_keep_and_trace(tmp_path):
    text = "table.restitution,x0,y0,x1,y1,vx,vy\n0.3,-0.25,0,0.1,0.05,1.2,0.6\n" \
           "0.9,-0.25,0,0.1,0.05,1.2,0.6\n"
    out = run_poolreps(["shoot", "--keep", "--trace", tmp_path / "t.csv"], input=text.encode())
    assert out.returncode == 0, out.stderr
    rows = read_csv(out.stdout.decode())
    assert rows[0][:7] == text.splitlines()[0].split(",") and rows[0][7] == "final_x0"
    assert [r[0] for r in rows[1:]] == ["0.3", "0.9"]
    assert rows[1][7:] != rows[2][7:]  # the cushions bounce differently
    trace = read_csv((tmp_path / "t.csv").read_text())
    assert {r[0] for r in trace[1:]} == {"0", "1"}
    for i, k in enumerate((0.3, 0.9)):
        one = "x0,y0,x1,y1,vx,vy\n-0.25,0,0.1,0.05,1.2,0.6\n"
        ref = run_poolreps(["shoot", "--set", f"table.restitution={k}"], input=one.encode())
        assert read_csv(ref.stdout.decode())[1] == rows[i + 1][7:]


OUTPUTS = ("final", "pocket", "hit", "min_gap", "reward", "t_end", "events")


@pytest.mark.parametrize("seed", range(3))
def test_threads_give_the_same_bytes_as_one_thread(seed):
    """shoot(threads=T) splits the rows over T threads, each with its own
    simulator; every output byte equals the one-thread batch's (and, with
    params, one call per row's), whatever T and whatever the rows cost."""
    rng = np.random.default_rng(200 + seed)
    n = 700 + 37 * seed  # parts of unequal size, more than 64 rows each
    states, actions = problem(seed, n, nballs=2 + seed)
    # cheap and costly rows mixed (speeds within sim.max_speed, 10 m/s)
    actions = np.clip(actions * rng.choice([0.1, 1.0, 8.0], size=(n, 1)), -7.0, 7.0)
    params = {"table.friction": rng.uniform(0.05, 2.0, n),
              "table.restitution": rng.uniform(0.0, 1.0, n)}
    params["table.friction"][::5] = 0.2  # runs of equal values reuse a simulator
    mode = "stepped" if seed == 2 else "event"
    for p in (None, params):
        want = poolreps.shoot(states, actions, mode=mode, params=p)
        for t in (2, 3, 0, 64, 1000):
            got = poolreps.shoot(states, actions, mode=mode, params=p, threads=t)
            for k in OUTPUTS:
                assert got[k].dtype == want[k].dtype
                assert got[k].tobytes() == want[k].tobytes(), (k, t, p is None)
    one = per_row(states[:50], actions[:50], {k: v[:50] for k, v in params.items()}, mode=mode)
    got = poolreps.shoot(states, actions, mode=mode, params=params, threads=4)
    for k in OUTPUTS:
        assert got[k][:50].tobytes() == one[k].tobytes(), k


def test_threads_name_the_first_bad_row():
    """Bad rows in two threads' parts: the message names the first, as one
    thread does; a bad threads value is refused."""
    n = 400
    states, actions = problem(1, n)
    fric = np.full(n, 0.3)
    fric[[300, 390]] = -1.0  # in the last parts of 2 and of 4 threads
    msgs = set()
    for t in (1, 2, 4, 0):
        with pytest.raises(ValueError) as e:
            poolreps.shoot(states, actions, params={"table.friction": fric}, threads=t)
        msgs.add(str(e.value))
    assert len(msgs) == 1 and "row 300" in msgs.pop()
    fric[10] = -1.0
    with pytest.raises(ValueError, match="row 10"):
        poolreps.shoot(states, actions, params={"table.friction": fric}, threads=4)
    for bad in (-1, 1.5, True, "2", None):
        with pytest.raises(ValueError, match="threads"):
            poolreps.shoot(states, actions, threads=bad)
