"""shoot, reps, Forest and Policy: the CLI's component commands on numpy arrays.

Each call runs the same C code as the matching `poolreps` command with the
same options and seed, so the numbers are equal bit for bit.
"""
from __future__ import annotations

import ctypes
import numbers
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import _lib
from ._lib import Handle, addr, array, check, config, count, errbuf, lib

ArrayLike = Any  # anything np.asarray takes
Keys = Optional[Dict[str, Any]]

# Version of the Python pickle of Forest and Policy (the dict __getstate__
# returns); a Forest's C part is in the library's own text format,
# PR_FOREST_FORMAT (docs/forest.md).
PICKLE_FORMAT = 1

# shoot: up to this many event-mode rows run without a worker thread
SHORT_ROWS = 64


def shoot(balls: ArrayLike, actions: ArrayLike, mode: str = "event",
          set: Keys = None, params: Keys = None, threads: int = 1) -> Dict[str, np.ndarray]:
    """Simulate one shot per row, as `poolreps shoot`.

    balls: (N, 2*n_balls) start positions x0, y0, x1, y1, ... (ball 0 is the
    cue ball); actions: (N, 2) the cue ball's initial velocity in m/s.
    mode: sim.mode ('event' or 'stepped'); set: other keys, e.g.
    {'table.friction': 0.3} (applied after mode, so they may override it).
    params: number keys of table., sim. and reward. with one value per row,
    (N,) arrays or scalars (broadcast), e.g. {'table.friction': f,
    'table.restitution': k}: row i is shot as with set={key: value[i]} on
    top of set, bit for bit (domain randomisation in one call).
    threads: the rows are split over up to this many threads (0: one per
    CPU; at least 64 rows a thread); every output is the same whatever the
    count.

    Returns a dict of arrays: final (N, n_balls, 2) final positions (a
    pocketed ball at its pocket's centre), pocket (N, n_balls) pocket id or
    -1, hit (N,) whether the cue ball touched a reward ball, min_gap (N,),
    reward (N,) (eq. 7.7), t_end (N,) seconds, events (N,) events (event
    mode) or steps (stepped mode).
    """
    cfg = config(_lib.assignments({"sim.mode": mode, **(set or {})}))
    # the simulator checks every row (finite, on the table, not overlapping,
    # not too fast) before shooting it: no second pass over the arrays here
    b = array("balls", balls, 2, allow_empty=True, finite=False)
    if b.shape[1] < 2 or b.shape[1] % 2:
        raise ValueError(f"balls: expected 2 columns per ball (x0, y0, x1, y1, ...), "
                         f"got shape {b.shape}")
    a = array("actions", actions, 2, cols=2, rows=b.shape[0], allow_empty=True, finite=False)
    return shoot_rows(cfg, b, a, row_params(params, b.shape[0]), threads)


RowParams = Optional[Tuple[Tuple[str, ...], np.ndarray]]


def row_params(params: Keys, n: int) -> RowParams:
    """(keys, (n, k) values) for shoot's params, or None for none."""
    if not params:
        return None
    keys = tuple(params)
    for k in keys:
        if not isinstance(k, str):
            raise ValueError(f"params: {k!r}: keys are 'section.key' strings")
    cols = []
    for k in keys:
        v = np.asarray(params[k])
        if v.ndim == 0:
            v = np.full(n, v, dtype=np.float64) if v.dtype.kind in "iuf" else v.reshape(1)
        cols.append(array(f"params[{k!r}]", v, 1, rows=n, allow_empty=True, finite=False))
    return keys, np.ascontiguousarray(np.stack(cols, axis=1).reshape(n, len(keys)))


def thread_count(threads: Any) -> int:
    """threads as an int >= 0 (0: one per CPU); ValueError otherwise."""
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, numbers.Integral) \
            or not 0 <= threads <= 2**31 - 1:
        raise ValueError(f"threads: must be an integer >= 0 (0: one per CPU), got {threads!r}")
    return int(threads)


def shoot_rows(cfg, b: np.ndarray, a: np.ndarray, params: RowParams = None,
               threads: int = 1, short: int = SHORT_ROWS) -> Dict[str, np.ndarray]:
    """shoot on checked arrays with a built Config and row_params' values.
    The rows run in a worker thread (_lib.interruptible): Ctrl-C reaches the
    caller at once, however long a row takes, and stops the worker at its
    next row. threads as for shoot. Up to short event-mode rows
    (microseconds each: a Gymnasium step) run directly, sparing the
    thread's start (about 0.1 ms, as much as 100 rows)."""
    n, nb = b.shape[0], b.shape[1] // 2
    out = {
        "final": np.empty((n, nb, 2)),
        "pocket": np.empty((n, nb), dtype=np.intc),
        "hit": np.empty(n, dtype=np.bool_),
        "min_gap": np.empty(n),
        "reward": np.empty(n),
        "t_end": np.empty(n),
        "events": np.empty(n, dtype=_lib.C_LONG),
    }
    err = errbuf()
    ptrs = [addr(out[k]) for k in ("final", "pocket", "hit", "min_gap", "reward", "t_end",
                                   "events")]
    keys, values = params if params else ((), None)
    nt = thread_count(threads)
    names = (ctypes.c_char_p * max(1, len(keys)))(*[k.encode() for k in keys])

    def call():  # no rows: the empty range all the same, which checks params' keys
        return lib.pr_bind_shoot_params(cfg.ptr, 0, n, nb, addr(b), addr(a), len(keys), names,
                                        addr(values), *ptrs, nt, err)
    if n <= short and cfg.values()["sim.mode"] == "event":
        _lib.settle()
        check(call(), err)
    else:
        check(_lib.interruptible(call, cfg, b, a, out, err, names, values), err)
    return out


def _reps_fields():
    fields, kind = [], ctypes.c_char()
    while True:
        name = lib.pr_bind_reps_field(len(fields), ctypes.byref(kind))
        if name is None:
            return fields
        fields.append((name.decode(), kind.value.decode()))


# The scalar fields of the C result, named by the library itself
# (src/bind.c): a field added there appears here with no change.
REPS_FIELDS = _reps_fields()


def _features(features, n):
    """Dense (n, d) float64, or CSR arrays for a scipy.sparse matrix."""
    if features is None:
        return 0, None, None
    if hasattr(features, "tocsr"):  # scipy.sparse, without importing scipy
        m = features.tocsr()
        if m.shape[0] != n:
            raise ValueError(f"features: expected {n} rows, got shape {m.shape}")
        if not m.has_sorted_indices:
            m = m.sorted_indices()  # a copy: the caller's matrix stays as it was
        data = array("features.data", m.data, 1, allow_empty=True)
        # all ones: the one-hot leaf features of eq. 5.4, solved by blocks
        csr = (np.ascontiguousarray(m.indptr, dtype=np.intc),
               np.ascontiguousarray(m.indices, dtype=np.intc),
               None if np.all(data == 1.0) else data)
        return count("features columns", m.shape[1]), None, csr
    f = np.asarray(features)
    f = array("features", f.reshape(-1, 1) if f.ndim == 1 else f, 2, rows=n, allow_empty=True)
    return count("features columns", f.shape[1]), (f if f.shape[1] else None), None


def reps(returns: ArrayLike, features: Any = None, epsilon: Optional[float] = None,
         base: Optional[ArrayLike] = None, set: Keys = None,
         solver: Optional[str] = None) -> Dict[str, Any]:
    """REPS weights for n samples, as `poolreps reps` (thesis ch. 3, eq. 3.7-3.8).

    returns: (n,) returns R_i; features: (n, d) state features phi_i (or
    (n,) for one, or a scipy.sparse matrix; None for none); epsilon: the KL
    bound (default: reps.epsilon, 0.5); base: (n,) base weights q_i >= 0
    (default: all 1); solver: "newton" (default), "nlopt" or "cg" (reps.solver);
    set: other reps.* keys.

    Returns a dict: p (n,) weights summing to 1 (they include q), theta (d,),
    and the solver's scalars eta, dual, kl, ess, bound, residual, iterations,
    the certificate kl_gap, residual_rel, status ("active" or "unreachable";
    "failed" only with reps.allow_failed = 1, otherwise NumericalError), and
    constant, reason (`poolreps reps --help` explains them).
    """
    keys = dict(set or {})
    if epsilon is not None:
        keys["reps.epsilon"] = epsilon
    if solver is not None:
        keys["reps.solver"] = solver
    cfg = config(_lib.assignments(keys, "reps", "reps."))
    R = array("returns", returns, 1)
    n = count("returns", R.shape[0])
    q = (_lib.weights("base", array("base", base, 1, rows=n), "base weight") if base is not None
         else np.ones(n))
    d, phi, csr = _features(features, n)
    rowptr, col, val = csr if csr else (None, None, None)
    res = ctypes.c_void_p()
    err = errbuf()
    rc = _lib.interruptible_call(lib.pr_bind_reps, cfg.ptr, n, d, addr(R), addr(q), addr(phi),
                                 addr(rowptr), addr(col), addr(val), ctypes.byref(res), err,
                                 keep=(cfg, R, q, phi, rowptr, col, val))
    check(rc, err)
    h = Handle(res.value, lib.pr_reps_result_free)
    out = {"p": np.ctypeslib.as_array(ctypes.cast(lib.pr_bind_reps_p(h.ptr),
                                                   ctypes.POINTER(ctypes.c_double)), (n,)).copy(),
           "theta": np.zeros(0)}
    if d:
        out["theta"] = np.ctypeslib.as_array(ctypes.cast(lib.pr_bind_reps_theta(h.ptr),
                                                         ctypes.POINTER(ctypes.c_double)),
                                              (d,)).copy()
    for i, (name, kind) in enumerate(REPS_FIELDS):
        if kind == "s":
            out[name] = lib.pr_bind_reps_text(h.ptr, i).decode()
            continue
        v = lib.pr_bind_reps_value(h.ptr, i)
        out[name] = int(v) if kind == "i" else v
    return out


class _Model:
    """Keys, a fitted C object behind a Handle, and the checks every method
    repeats. Safe to share between threads: a fit builds a new object and
    swaps it in; running calls keep the one they started with."""

    _section = None
    _keys = None   # the keys its command reads (the CLI's list)

    def __init__(self, **keys: Any) -> None:
        self._sets = _lib.assignments(keys, self._section, self._keys)
        self._cfg = config(self._sets)
        self._h = None

    def __repr__(self) -> str:
        keys = ", ".join(repr(a) for a in self._sets)
        h = self._h
        return f"{type(self).__name__}({keys}){' fitted: ' + self._describe(h) if h else ''}"

    def _describe(self, h) -> str:
        return ""

    def _state(self, h) -> Dict[str, Any]:
        raise NotImplementedError

    def __getstate__(self) -> Dict[str, Any]:
        h = self._h
        return {"format": PICKLE_FORMAT, "class": type(self).__name__, "sets": self._sets,
                "fit": None if h is None else self._state(h)}

    def __setstate__(self, st: Dict[str, Any]) -> None:
        v = st.get("format") if isinstance(st, dict) else None
        if v != PICKLE_FORMAT:
            raise ValueError(f"{type(self).__name__}: pickle format version {v}, this "
                             f"poolreps reads version {PICKLE_FORMAT}")
        self._sets = tuple(st["sets"])
        self._cfg = config(self._sets)
        self._h = None
        if st["fit"] is not None:
            self._restore(st["fit"])

    def get_params(self) -> Dict[str, str]:
        """The effective {section.key: value} of this model's section, and the seed."""
        v = self._cfg.values()
        return {k: x for k, x in v.items()
                if k.startswith(self._section + ".") or k == "experiment.seed"}

    def _fitted(self):
        h = self._h
        if h is None:
            raise ValueError(f"{type(self).__name__}: call fit() first")
        return h

    def _fit(self, fn, free, meta, *args, keep=()):
        out = ctypes.c_void_p()
        err = errbuf()
        check(_lib.interruptible_call(fn, self._cfg.ptr, *args, ctypes.byref(out), err,
                                      keep=(self._cfg,) + keep), err)
        self._h = Handle(out.value, free, meta)
        return self


class Forest(_Model):
    """Extremely randomized trees (thesis ch. 4), as `poolreps forest`.

    Keys are forest.* (`trees=50` means forest.trees = 50) and `seed`
    (experiment.seed, default 1); the same keys and seed give the same forest
    and predictions as the command.
    """

    _section = "forest"
    _keys = "forest.,experiment.seed"

    def _describe(self, h) -> str:
        return (f"{lib.pr_forest_ntrees(h.ptr)} trees, {lib.pr_forest_nleaves(h.ptr)} leaves, "
                f"{lib.pr_forest_dx(h.ptr)} inputs, {lib.pr_forest_dy(h.ptr)} outputs")

    def save_text(self) -> bytes:
        """The fitted forest in the library's text format (docs/forest.md):
        what `poolreps forest --save` writes, with inputs x0.. and outputs y0..;
        `Forest.from_text` and `poolreps forest --load` read it back."""
        h = self._fitted()
        text, n = ctypes.c_void_p(), ctypes.c_size_t()
        err = errbuf()
        check(lib.pr_forest_to_text(h.ptr, None, ctypes.byref(text), ctypes.byref(n), err), err)
        try:
            return ctypes.string_at(text.value, n.value)
        finally:
            lib.pr_bind_free(text)

    @classmethod
    def from_text(cls, text: bytes, one_output: bool = False, **keys: Any) -> "Forest":
        """A fitted Forest from the text `save_text` or `poolreps forest
        --save` wrote (ValueError naming both versions for another format
        version, OSError for a malformed file); keys as for Forest();
        one_output: predict returns (n,) as after a fit on 1-D y."""
        f = cls(**keys)
        f._restore({"text": text, "one_output": one_output})
        return f

    def _state(self, h) -> Dict[str, Any]:
        return {"text": self.save_text(), "one_output": bool(h.meta)}

    def _restore(self, fit: Dict[str, Any]) -> None:
        text = bytes(fit["text"])
        err = errbuf()
        ptr = lib.pr_forest_load(text, len(text), b"forest", None, err)
        if not ptr:
            msg = err.value.decode(errors="replace")
            if "out of memory" in msg:
                raise MemoryError(msg)
            raise (ValueError if "format version" in msg else OSError)(msg)
        self._h = Handle(ptr, lib.pr_forest_free, bool(fit["one_output"]))

    def fit(self, X: ArrayLike, y: ArrayLike, sample_weight: Optional[ArrayLike] = None) -> "Forest":
        """X (n, d) inputs, y (n,) or (n, k) targets, sample_weight (n,) >= 0
        (eq. 6.2-6.3; default all 1). Returns self."""
        X = array("X", X, 2)
        n = count("X", X.shape[0])
        y = np.asarray(y)
        Y = array("y", y.reshape(-1, 1) if y.ndim == 1 else y, 2, rows=n)
        w = (None if sample_weight is None else
             _lib.weights("sample_weight", array("sample_weight", sample_weight, 1, rows=n), "weight"))
        return self._fit(lib.pr_bind_forest_fit, lib.pr_forest_free, y.ndim == 1, n, X.shape[1],
                         Y.shape[1], addr(X), addr(Y), addr(w), keep=(X, Y, w))

    def _inputs(self, h, X):
        return array("X", X, 2, cols=lib.pr_forest_dx(h.ptr), allow_empty=True)

    def predict(self, X: ArrayLike) -> np.ndarray:
        """Mean over trees of the leaf values (eq. 4.2-4.3): (n,) or (n, k)."""
        h = self._fitted()
        X = self._inputs(h, X)
        n = count("X", X.shape[0])
        dx, dy = X.shape[1], lib.pr_forest_dy(h.ptr)
        Y = np.empty((n, dy))
        _lib.rows_interruptibly(n, lambda lo, hi: lib.pr_forest_predict_many(
            h.ptr, addr(X) + 8 * lo * dx, hi - lo, addr(Y) + 8 * lo * dy), self._row_work(h) * dy)
        if not np.isfinite(Y).all():
            # as the CLI, which refuses to write it (exit 3): never a silent inf or NaN
            i = int(np.argmin(np.isfinite(Y).all(axis=1)))
            raise _lib.NumericalError(f"predict: row {i}: refusing to return a non-finite number "
                                      "(numerical failure)")
        return Y[:, 0].copy() if h.meta else Y

    def apply(self, X: ArrayLike) -> np.ndarray:
        """Each row's leaf in each tree, numbered within the tree: (n, trees)
        (the `--leaves` output; like scikit-learn's apply)."""
        h = self._fitted()
        X = self._inputs(h, X)
        M, dx = lib.pr_forest_ntrees(h.ptr), X.shape[1]
        out = np.empty((X.shape[0], M), dtype=np.intc)
        err = errbuf()
        _lib.rows_interruptibly(X.shape[0], lambda lo, hi: check(lib.pr_bind_forest_apply(
            h.ptr, hi - lo, addr(X) + 8 * lo * dx, addr(out) + out.itemsize * lo * M, err), err),
            self._row_work(h))
        return out

    @staticmethod
    def _row_work(h):
        # a row visits at most every node of every tree: fewer than 2 x leaves
        return 2 * lib.pr_forest_tree_leaf0(h.ptr, lib.pr_forest_ntrees(h.ptr))

    @property
    def leaf_offsets(self) -> np.ndarray:
        """(trees + 1,): tree t's leaves are global ids leaf_offsets[t] to
        leaf_offsets[t + 1] - 1; the last entry is the number of leaves."""
        h = self._fitted()
        return np.array([lib.pr_forest_tree_leaf0(h.ptr, t)
                         for t in range(lib.pr_forest_ntrees(h.ptr) + 1)])

    def leaf_features(self, X: ArrayLike) -> np.ndarray:
        """The active-leaf features of eq. 5.1-5.4: (n, leaves), 1 where the
        row falls into the leaf (one per tree), else 0."""
        leaves = self.apply(X) + self.leaf_offsets[:-1]
        phi = np.zeros((leaves.shape[0], self.leaf_offsets[-1]))
        np.put_along_axis(phi, leaves, 1.0, axis=1)
        return phi


# a policy query walks its forest and solves a small fit: fewer rows per piece
POLICY_CHUNK = 1024


def _policy_rows(p, h, nq, piece, draws=1):
    """piece(lo, hi) over nq states of policy p (handle h), interruptible
    (_lib.rows_interruptibly). A state's work is bounded by a walk through
    every node of every tree (fewer than 2 x samples each), a fit over all
    samples, and its draws."""
    n, ds = h.meta["S"].shape
    da = lib.pr_policy_da(h.ptr)
    trees = int(p._cfg.values()["policy.trees"])
    work = n * (2 * trees + (ds + 1) ** 2 * (da + 1)) + draws * (da + 1) ** 2
    _lib.rows_interruptibly(nq, piece, work, POLICY_CHUNK)


class Policy(_Model):
    """The tree-based locally weighted regression Gaussian policy (thesis
    ch. 6, eq. 6.4-6.9), as `poolreps policy`.

    Keys are policy.* (`n_min=40` means policy.n_min = 40) and `seed`.
    """

    _section = "policy"
    _keys = "policy.,experiment.seed"

    def _describe(self, h) -> str:
        return f"{h.meta['S'].shape[0]} samples, {lib.pr_policy_ds(h.ptr)} state, " \
               f"{lib.pr_policy_da(h.ptr)} action dimensions"

    def _state(self, h) -> Dict[str, Any]:
        # the fit is deterministic (its forest is seeded by experiment.seed):
        # its inputs are the policy, refitted bit for bit on unpickling
        return dict(h.meta)

    def _restore(self, fit: Dict[str, Any]) -> None:
        self.fit(fit["S"], fit["A"], fit["w"], fit["target"])

    def fit(self, S: ArrayLike, A: ArrayLike, w: Optional[ArrayLike],
            target: Optional[ArrayLike] = None) -> "Policy":
        """S (n, ds) states, A (n, da) actions, w (n,) REPS weights >= 0
        (None: all 1); target (n, dy) the final reward-ball positions the
        forest learns when policy.target = reward_state. Returns self."""
        S = array("S", S, 2)
        n = count("S", S.shape[0])
        A = array("A", A, 2, rows=n)
        w = None if w is None else _lib.weights("w", array("w", w, 1, rows=n), "weight")
        Y = None if target is None else array("target", target, 2, rows=n)
        meta = {"S": S.copy(), "A": A.copy(), "w": None if w is None else w.copy(),
                "target": None if Y is None else Y.copy()}
        return self._fit(lib.pr_bind_policy_fit, lib.pr_policy_free, meta, n, S.shape[1],
                         A.shape[1], 0 if Y is None else Y.shape[1], addr(S), addr(A), addr(w),
                         addr(Y), keep=(S, A, w, Y))

    def _states(self, h, S):
        S = array("S", S, 2, cols=lib.pr_policy_ds(h.ptr), allow_empty=True)
        return S, S.shape[0], lib.pr_policy_da(h.ptr)

    def mean_cov(self, S: ArrayLike, status: bool = False) -> Tuple[np.ndarray, ...]:
        """Mean (nq, da) and covariance (nq, da, da) at each state; with
        status, also the fallback bits per state (1 global fit, 2
        pseudo-inverse, 4 mean only, 8 covariance fallback, 16 min_std floor)."""
        h = self._fitted()
        S, nq, da = self._states(h, S)
        mean, cov = np.empty((nq, da)), np.empty((nq, da, da))
        st = np.empty(nq, dtype=np.intc)
        err = errbuf()
        ds = S.shape[1]
        _policy_rows(self, h, nq, lambda lo, hi: check(lib.pr_bind_policy_eval(
            h.ptr, hi - lo, addr(S) + 8 * lo * ds, addr(mean) + 8 * lo * da,
            addr(cov) + 8 * lo * da * da, addr(st) + st.itemsize * lo, err), err))
        return (mean, cov, st) if status else (mean, cov)

    def sample(self, S: ArrayLike, seed: int, n: Optional[int] = None) -> np.ndarray:
        """One action per state, (nq, da), or n per state, (nq, n, da), drawn
        from a generator seeded with seed: the draws of `poolreps policy
        --seed SEED --sample N` for a policy fitted with the same seed."""
        h = self._fitted()
        S, nq, da = self._states(h, S)
        k = 1 if n is None else _lib.seed_value("n", n)
        if not 1 <= k <= 1000000:
            raise ValueError(f"n: must be an integer in 1..1000000 (got {n})")
        rng = _lib.rng_handle(lib.pr_bind_policy_rng_new(_lib.seed_value("seed", seed)))
        draws = np.empty((nq, k, da))
        st = np.empty(nq, dtype=np.intc)
        err = errbuf()
        ds = S.shape[1]
        _policy_rows(self, h, nq, lambda lo, hi: check(lib.pr_bind_policy_sample_rng(
            h.ptr, hi - lo, addr(S) + 8 * lo * ds, k, rng.ptr, addr(draws) + 8 * lo * k * da,
            addr(st) + st.itemsize * lo, err), err), k)
        return draws[:, 0, :].copy() if n is None else draws

    def log_prob(self, S: ArrayLike, A: ArrayLike) -> np.ndarray:
        """log pi(a|s) for each row: (nq,)."""
        h = self._fitted()
        S, nq, da = self._states(h, S)
        A = array("A", A, 2, cols=da, rows=nq, allow_empty=True)
        lp = np.empty(nq)
        st = np.empty(nq, dtype=np.intc)
        err = errbuf()
        ds = S.shape[1]
        _policy_rows(self, h, nq, lambda lo, hi: check(lib.pr_bind_policy_logpdf(
            h.ptr, hi - lo, addr(S) + 8 * lo * ds, addr(A) + 8 * lo * da, addr(lp) + 8 * lo,
            addr(st) + st.itemsize * lo, err), err))
        return lp
