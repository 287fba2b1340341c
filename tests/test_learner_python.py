"""poolreps.Learner: the same bits as `poolreps learner` for the same seed
and keys; pickled and deep-copied learners go on with the same draws; bad
input is a ValueError naming the argument and row, and changes nothing."""
import copy
import pickle
import sys

import numpy as np
import pytest

from conftest import ROOT, run_poolreps

sys.path.insert(0, str(ROOT / "python"))
import poolreps  # noqa: E402

KEYS = {"learner.window": 40, "policy.n_min": 15, "value.n_min": 10}


def returns(X, A):
    best = np.stack([0.5 + X[:, 0] - X[:, 1], -0.3 + 0.8 * X[:, 1]], axis=1)
    return -((A - best) ** 2).sum(axis=1)


def write(path, header, m):
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in m:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def cli_ask(tmp_path, st, X, names=("x", "y")):
    write(tmp_path / "c.csv", names, X)
    r = run_poolreps(["learner", "ask", st, "-i", tmp_path / "c.csv", "-o", tmp_path / "a.csv"])
    assert r.returncode == 0, r.stderr
    m = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1, ndmin=2)
    assert np.array_equal(m[:, :2], X)
    return m[:, 2:]


def cli_tell(tmp_path, st, X, A, R, names=("x", "y", "a", "b")):
    write(tmp_path / "e.csv", [*names, "ret"], np.column_stack([X, A, R]))
    r = run_poolreps(["learner", "tell", st, "--return", "ret", "-i", tmp_path / "e.csv"])
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("value,policy", [("nrvr", "tree"), ("linear", "linear")])
@pytest.mark.usefixtures("poolreps")
def test_same_bits_as_the_command_line(tmp_path, value, policy):
    st = tmp_path / "st"
    sets = [a for k, v in {**KEYS, "learner.value": value, "learner.policy": policy}.items()
            for a in ("--set", f"{k}={v}")]
    r = run_poolreps(["learner", "new", st, "--context", "x,y", "--action", "a,b", "--seed", "7"]
                     + sets)
    assert r.returncode == 0, r.stderr
    L = poolreps.Learner(2, 2, value=value, policy=policy, seed=7, set=KEYS)
    rng = np.random.default_rng(3)
    for _ in range(4):
        X = rng.uniform(-1, 1, (12, 2))
        A = L.ask(X)
        assert np.array_equal(A, cli_ask(tmp_path, st, X))
        R = returns(X, A)
        L.tell(X, A, R)
        cli_tell(tmp_path, st, X, A, R)
    X = rng.uniform(-1, 1, (5, 2))
    write(tmp_path / "m.csv", ["x", "y"], X)
    r = run_poolreps(["learner", "mean", st, "-i", tmp_path / "m.csv", "-o", tmp_path / "mo.csv"])
    assert r.returncode == 0, r.stderr
    m = np.loadtxt(tmp_path / "mo.csv", delimiter=",", skiprows=1, ndmin=2)
    assert np.array_equal(L.mean(X), m[:, 2:])


@pytest.mark.parametrize("names", [None, ("x", "y", "a", "b")])
@pytest.mark.usefixtures("poolreps")
def test_a_state_saved_from_python_goes_through_the_command_line(tmp_path, names):
    """Python saves, `poolreps learner` asks and tells on the file, Python
    loads it back: the same actions and the same state bytes as a learner
    that stayed in Python throughout. Without names the columns are s0, s1,
    a0, a1."""
    kw = {} if names is None else {"context_names": names[:2], "action_names": names[2:]}
    cols = names or ("s0", "s1", "a0", "a1")
    L = poolreps.Learner(2, 2, value="nrvr", seed=4, set=KEYS, **kw)
    M = copy.deepcopy(L)  # stays in Python
    assert (L.context_names, L.action_names) == (list(cols[:2]), list(cols[2:]))
    rng = np.random.default_rng(8)
    st = tmp_path / "st"
    for t in range(4):
        X = rng.uniform(-1, 1, (12, 2))
        if t % 2 == 0:  # the command line plays this iteration
            st.write_bytes(L.save())
            A = cli_ask(tmp_path, st, X, cols[:2])
            cli_tell(tmp_path, st, X, A, returns(X, A), cols)
            L = poolreps.Learner.load(st.read_bytes())
        else:
            A = L.ask(X)
            L.tell(X, A, returns(X, A))
        B = M.ask(X)
        assert np.array_equal(A, B)
        M.tell(X, B, returns(X, B))
    assert L.save() == M.save() and L.context_names == list(cols[:2])


def test_column_names_are_checked():
    with pytest.raises(ValueError, match="context_names"):
        poolreps.Learner(2, 1, context_names=["x"])
    with pytest.raises(ValueError, match="action_names"):
        poolreps.Learner(2, 1, action_names="a")
    for unordered in ({"x", "y"}, {"x": 0, "y": 1}, (c for c in "xy")):
        with pytest.raises(ValueError, match="context_names: must be a sequence"):
            poolreps.Learner(2, 1, context_names=unordered)
    with pytest.raises(ValueError, match="action name 0 'x' is also context name 0"):
        poolreps.Learner(2, 1, context_names=["x", "y"], action_names=["x"])
    with pytest.raises(ValueError, match="context name 1 must be"):
        poolreps.Learner(2, 1, context_names=["x", "y\n"])
    with pytest.raises(ValueError, match="action name 0 must be"):  # a CSV header trims it
        poolreps.Learner(2, 1, action_names=["a "])
    with pytest.raises(ValueError, match="action name 0 's1' is also context name 1"):
        poolreps.Learner(2, 1, action_names=["s1"])  # the default context names


def test_a_name_is_kept_whole_or_refused():
    """A NUL would end a name in C: refused with the argument and index,
    as is a string that has no bytes; other names come back as given."""
    with pytest.raises(ValueError, match=r"context_names\[1\]: a NUL byte"):
        poolreps.Learner(2, 1, context_names=["x", "y\0z"])
    with pytest.raises(ValueError, match=r"action_names\[0\]: .* cannot be encoded"):
        poolreps.Learner(2, 1, action_names=["\ud800"])
    names = ["é,\"q\"", "s\udcff"]
    L = poolreps.Learner(2, 1, context_names=names, action_names=["a b"])
    M = poolreps.Learner.load(L.save())
    assert M.context_names == names and M.action_names == ["a b"]


def test_a_load_error_is_typed_by_what_failed_not_by_its_name():
    """A truncated state is an OSError whatever `what` says; another
    format version a ValueError."""
    good = poolreps.Learner(1, 1).save()
    for what in ("state", "version", "my learner format version 2"):
        with pytest.raises(OSError, match="truncated"):
            poolreps.Learner.load(good[:100], what)
    with pytest.raises(ValueError, match="version 9"):
        poolreps.Learner.load(good[:17] + b"\x09" + good[18:], "version")


@pytest.mark.parametrize("field,name", [(5, "value.trees"), (6, "value.cuts"),
                                        (20, "policy.trees"), (21, "policy.cuts")])
def test_a_state_asking_for_endless_forests_is_refused(field, name):
    """The options in a state are bounded as their keys are: 2^31 - 1 trees
    or random tests per node would make a tell run for days."""
    import struct
    s = bytearray(poolreps.Learner(1, 1).save())
    struct.pack_into("<i", s, 21 + 4 * field, 2**31 - 1)  # after the magic and version
    with pytest.raises(OSError, match=f"not a valid learner state: {name}: must be <= 10000"):
        poolreps.Learner.load(bytes(s))


def trained(n=4, **kw):
    L = poolreps.Learner(2, 2, seed=5, set=KEYS, **kw)
    rng = np.random.default_rng(9)
    for _ in range(n):
        X = rng.uniform(-1, 1, (15, 2))
        A = L.ask(X)
        L.tell(X, A, returns(X, A))
    return L, rng


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_copy_continues_with_the_same_draws(how):
    L, rng = trained()
    X = rng.uniform(-1, 1, (15, 2))
    pending = L.ask(X)  # an ask in flight is part of the state
    M = pickle.loads(pickle.dumps(L)) if how == "pickle" else copy.deepcopy(L)
    assert M.iteration == L.iteration == 4 and M.summary == L.summary
    for K in (L, M):
        K.tell(X, pending, returns(X, pending))
    for _ in range(3):
        X = rng.uniform(-1, 1, (15, 2))
        A, B = L.ask(X), M.ask(X)
        assert np.array_equal(A, B)
        L.tell(X, A, returns(X, A))
        M.tell(X, B, returns(X, B))
    assert L.save() == M.save()


@pytest.mark.parametrize("how", ["pickle", "deepcopy", "load"])
def test_a_copy_saves_the_same_bytes(how):
    """After a tell (no ask in flight) a copy's state is the original's,
    byte for byte: an empty window is saved the same whether it was
    emptied by a tell or read back empty."""
    L, _ = trained(2)
    M = {"pickle": lambda: pickle.loads(pickle.dumps(L)), "deepcopy": lambda: copy.deepcopy(L),
         "load": lambda: poolreps.Learner.load(L.save())}[how]()
    assert M.save() == L.save()


def test_a_failed_restore_leaves_the_learner_working():
    """__setstate__ on a live learner with a bad state raises and leaves
    it as it was, its random stream included (it was freed under it)."""
    L, rng = trained(2)
    before = L.save()
    for st, err in [({"format": 1, "state": b"junk"}, OSError),
                    ({"format": 1, "state": before[:60]}, OSError),
                    ({"format": 1}, ValueError), ({"format": 1, "state": "text"}, ValueError)]:
        with pytest.raises(err):
            L.__setstate__(st)
        assert L.save() == before
    X = rng.uniform(-1, 1, (5, 2))
    assert np.array_equal(L.ask(X), poolreps.Learner.load(before).ask(X))


def test_a_row_the_policy_fails_at_is_named():
    """A context far beyond the fitted ones overflows the tree policy's
    covariance: NumericalError naming the row, the learner unchanged."""
    L, rng = trained(2)
    before = L.save()
    X = np.r_[rng.uniform(-1, 1, (3, 2)), [[0.5, -1e200]]]
    for call in (L.ask, L.mean):
        with pytest.raises(poolreps.NumericalError, match=r"^contexts: row 3: policy: covariance"):
            call(X)
        assert L.save() == before


def test_threads_sharing_a_learner_take_turns():
    """ask, tell, mean and save from four threads on one learner: the
    library runs without the GIL, and two calls at once corrupted the
    learner (the interpreter died of a segmentation fault). Each call now
    holds the learner's lock: every tell counts, nothing fails."""
    import threading
    L = poolreps.Learner(2, 2, value="linear", policy="linear", seed=1, set={"learner.window": 200})
    errors = []

    def work(k):
        rng = np.random.default_rng(k)
        try:
            for _ in range(200):
                X = rng.uniform(-1, 1, (50, 2))
                A = L.ask(X)
                L.tell(X, A, returns(X, A))
                L.mean(X), L.save(), L.summary, L.context_names
        except Exception as e:  # noqa: BLE001 (any failure is the test's)
            errors.append(e)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == [] and L.iteration == 800


def test_bad_input_names_the_argument_and_changes_nothing():
    L, rng = trained(2)
    X = rng.uniform(-1, 1, (6, 2))
    A = L.ask(X)
    R = returns(X, A)
    before = L.save()
    cases = [((X, A, np.r_[R[:-1], np.nan]), "returns[5]"),
             ((np.r_[X[:2], [[0, np.inf]], X[3:]], A, R), "contexts[2, 1]"),
             ((X, A[:, :1], R), "actions"),
             ((X, A, R[:4]), "returns"),
             ((X[:0], A[:0], R[:0]), "contexts"),
             ((X, A, R, np.zeros((6, 1))), "features"),
             ((X, A, R, None, np.zeros((6, 2))), "targets: given, but only the tree policy")]
    for args, want in cases:
        with pytest.raises(ValueError, match=want.replace("[", r"\[")):
            L.tell(*args)
        assert L.save() == before
    with pytest.raises(ValueError, match=r"^learner: 1 episode to weigh \(the first tell\)"):
        poolreps.Learner(1, 1).tell([[0.0]], [[0.0]], [0.0])  # not 'reps: ... samples'
    with pytest.raises(ValueError, match="context_dim"):
        poolreps.Learner(0, 2)
    with pytest.raises(ValueError, match="learner.value"):
        poolreps.Learner(1, 1, value="cubic")
    with pytest.raises(ValueError, match="learner.window"):
        poolreps.Learner(1, 1, set={"learner.window": 1})
    # pi_0's covariance init_std^2 must not underflow to 0
    with pytest.raises(ValueError, match="learner.init_std: 1e-200 out of range"):
        poolreps.Learner(1, 1, set={"learner.init_std": 1e-200})
    # a key the learner never reads would be ignored, as `learner new --set` refuses it
    for key in ("exp3.iterations", "forest.trees", "sim.dt"):
        with pytest.raises(ValueError, match=f"learner: --set {key} does not apply"):
            poolreps.Learner(1, 1, set={key: 3})
    with pytest.raises(OSError, match="truncated"):
        poolreps.Learner.load(before[:100])


def test_summary_is_the_certificate():
    L, _ = trained(3)
    s = L.summary
    assert s["iteration"] == 3 and s["n"] == 40 and s["status"] in ("active", "unreachable")
    assert s["features"] > 0 and s["q_ess"] <= 40 + 1e-9
    assert (s["status"] == "active") == bool(s["bound"]) and s["reason"] == ""
    if s["bound"]:
        assert abs(s["kl"] - 0.5) < 1e-6


def test_a_discontinuous_optimum_at_default_settings():
    """Contexts in [-1, 1]^2, one action, the best action +1 on one side of
    the line s0 + s1 / 2 = 0.2 and -1 on the other, return -(a - best)^2:
    within 10,000 episodes (200 tells of 50) the mean action's expected loss
    falls at least 5-fold from that of pi_0's mean (1), on 2000 test contexts."""
    def ret(S, A):
        return -(A[:, 0] - np.where(S[:, 0] + 0.5 * S[:, 1] > 0.2, 1.0, -1.0)) ** 2

    L = poolreps.Learner(2, 1, seed=0)
    rng = np.random.default_rng(0)
    T = rng.uniform(-1, 1, (2000, 2))
    d0 = -ret(T, L.mean(T)).mean()
    for _ in range(200):
        S = rng.uniform(-1, 1, (50, 2))
        A = L.ask(S)
        L.tell(S, A, ret(S, A))
    d1 = -ret(T, L.mean(T)).mean()
    assert d0 == 1.0 and L.iteration == 200
    assert d1 * 5 < d0, d1


def test_an_uncertified_solve_is_a_numerical_error_and_changes_nothing():
    L = poolreps.Learner(2, 2, seed=1, set={"reps.max_iter": 1})
    X = np.random.default_rng(1).uniform(-1, 1, (30, 2))
    A = L.ask(X)
    before = L.save()
    with pytest.raises(poolreps.NumericalError, match="not certified"):
        L.tell(X, A, returns(X, A))
    assert L.save() == before and L.iteration == 0
