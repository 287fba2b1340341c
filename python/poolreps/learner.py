"""poolreps.Learner: the ask/tell learner of the C library (learner.h) on
numpy arrays.

    L = Learner(context_dim, action_dim, value="trees", policy="tree", seed=0, set=None,
                context_names=None, action_names=None)
    A = L.ask(contexts)                  # (n, action_dim): one draw per context
    L.tell(contexts, actions, returns)   # one iteration: REPS and a new policy
    L.mean(contexts), L.iteration, L.summary

Keys are the CLI's ({'section.key': value}, checked as --set checks them;
those of learner., value., reps., policy. and experiment.seed: another
would be ignored, so it is refused); value and policy are learner.value
and learner.policy, seed is experiment.seed. The stream is a GSL mt19937 set to the seed, as `poolreps
learner new --seed` sets it, so the same seed and keys give the same bits
as the command line. A pickled or deep-copied learner goes on with the same
draws (its state is the library's saved state, random stream included).
init_mean (action_dim numbers) is pi_0's mean instead of 0; such a learner
is saved once pi_0's episodes have left the window. save() gives the bytes
of a STATE file: `poolreps learner ask|tell|mean`
read its context and action columns by the names given here (default s0 ..,
a0 ..), and Learner.load reads what they wrote.
"""
import ctypes
import threading
from ctypes import POINTER, c_char_p, c_double, c_int, c_size_t, c_void_p
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _lib
from ._lib import Handle, addr, array, assignments, check, config, errbuf, lib, rng_handle

_P = c_void_p
for _name, (_res, _args) in {
    "pr_bind_learner_new": (_P, [_P, c_int, c_int, _P, _P, _P, c_char_p]),
    "pr_bind_learner_tell": (c_int, [_P, c_int, _P, _P, _P, _P, c_int, _P, c_int, c_char_p]),
    "pr_bind_learner_summary": (c_char_p, [_P, _P, _P, _P]),
    "pr_learner_ask": (c_int, [_P, c_int, _P, _P, c_char_p]),
    "pr_learner_mean": (c_int, [_P, c_int, _P, _P, c_char_p]),
    "pr_learner_save": (c_int, [_P, POINTER(_P), POINTER(c_size_t), c_char_p]),
    "pr_learner_load": (_P, [c_char_p, c_size_t, c_char_p, _P, c_char_p]),
    "pr_learner_free": (None, [_P]),
    "pr_learner_iteration": (c_int, [_P]),
    "pr_learner_context_dim": (c_int, [_P]),
    "pr_learner_action_dim": (c_int, [_P]),
}.items():
    _f = getattr(lib, _name)
    _f.restype = _res
    _f.argtypes = _args

STATUS = ("active", "unreachable", "failed")
PICKLE_FORMAT = 1


def _dim(name, v, hi):
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or not 1 <= v <= hi:
        raise ValueError(f"{name}: must be an integer in 1..{hi} (got {v!r})")
    return int(v)


def _names(name, v, n):
    """A list of n column names as bytes (None: the library's defaults)."""
    if v is None:
        return None
    # a sequence, in its order: a set's or a generator's order is not the caller's
    if isinstance(v, (str, bytes)) or not isinstance(v, (Sequence, np.ndarray)) \
            or len(v) != n or not all(isinstance(x, str) for x in v):
        raise ValueError(f"{name}: must be a sequence of {n} strings (got {v!r})")
    out = []
    for i, x in enumerate(v):
        # bytes as os.fsencode gives them; a NUL would end the name in C:
        # refused, not cut short
        try:
            b = x.encode(errors="surrogateescape")
        except UnicodeEncodeError as e:
            raise ValueError(f"{name}[{i}]: {x!r} cannot be encoded: {e.reason}") from None
        if b"\0" in b:
            raise ValueError(f"{name}[{i}]: a NUL byte in the name {x!r}")
        out.append(b)
    return out


class Learner:
    """The thesis's method as an ask/tell learner: value features from
    extremely randomized trees, episodic contextual REPS over a window of
    past episodes, a tree-LWR (or linear) Gaussian policy refitted each tell."""

    def __init__(self, context_dim: int, action_dim: int, *, value: str = "trees",
                 policy: str = "tree", seed: int = 0, set: Optional[Dict[str, Any]] = None,
                 context_names: Optional[Sequence[str]] = None,
                 action_names: Optional[Sequence[str]] = None, init_mean: Any = None):
        self._lock = threading.Lock()
        dx, da = _dim("context_dim", context_dim, 100000), _dim("action_dim", action_dim, 64)
        cn, an = _names("context_names", context_names, dx), _names("action_names", action_names, da)
        names = (c_char_p * (dx + da))(*(cn or [None] * dx), *(an or [None] * da))
        mu = None if init_mean is None else array("init_mean", init_mean, 1, rows=da)
        keys = {"learner.value": value, "learner.policy": policy,
                "experiment.seed": _lib.seed_value("seed", seed)}
        keys.update(set or {})
        cfg = config(assignments(keys, "learner", "learner.,experiment.seed,value.,reps.,policy."))
        self._rng = rng_handle(lib.pr_bind_rng_new(int(float(cfg.number("experiment.seed")))))
        err = errbuf()
        ptr = lib.pr_bind_learner_new(cfg.ptr, dx, da, names, addr(mu), self._rng.ptr, err)
        if not ptr:
            check(_lib.PR_EINVAL, err)
        self._h = Handle(ptr, lib.pr_learner_free)
        self._dx, self._da = dx, da

    # ---- the loop ----

    def _call(self, fn, *args):
        """fn(learner, *args) with the learner locked: the library releases the
        GIL, and two threads in one learner at once would corrupt it."""
        with self._lock:
            return fn(self._h.ptr, *args)

    def _contexts(self, contexts):
        return array("contexts", contexts, 2, cols=self._dx)

    def ask(self, contexts) -> np.ndarray:
        """One action per context row, drawn from the current policy: (n, action_dim)."""
        X = self._contexts(contexts)
        A = np.empty((X.shape[0], self._da))
        err = errbuf()
        check(self._call(lib.pr_learner_ask, _lib.count("contexts", X.shape[0]), addr(X), addr(A),
                         err), err)
        return A

    def mean(self, contexts) -> np.ndarray:
        """The current policy's mean action per context row: (n, action_dim)."""
        X = self._contexts(contexts)
        A = np.empty((X.shape[0], self._da))
        err = errbuf()
        check(self._call(lib.pr_learner_mean, _lib.count("contexts", X.shape[0]), addr(X),
                         addr(A), err), err)
        return A

    def tell(self, contexts, actions, returns, features=None, targets=None) -> None:
        """One iteration on n episodes: they join the window, the value
        features are built, REPS weighs the window, the policy is refitted.
        features (n, d): for value="given"; targets (n, dy): for
        policy.target = reward_state. A failed tell changes nothing."""
        X = self._contexts(contexts)
        n = X.shape[0]
        A = array("actions", actions, 2, cols=self._da, rows=n)
        R = array("returns", returns, 1, rows=n)
        G = None if features is None else array("features", features, 2, rows=n)
        Y = None if targets is None else array("targets", targets, 2, rows=n)
        err = errbuf()
        check(self._call(lib.pr_bind_learner_tell, _lib.count("contexts", n), addr(X), addr(A),
                         addr(R), addr(G), 0 if G is None else G.shape[1], addr(Y),
                         0 if Y is None else Y.shape[1], err), err)

    @property
    def iteration(self) -> int:
        """Tells so far."""
        return self._call(lib.pr_learner_iteration)

    @property
    def summary(self) -> Dict[str, Any]:
        """The last tell's REPS certificate and fit."""
        d = (c_double * 7)()
        i = (c_int * 7)()
        reason = self._call(lib.pr_bind_learner_summary, d, i, None).decode(errors="replace")
        out = dict(zip(("eta", "kl", "ess", "q_ess", "residual", "kl_gap", "residual_rel"),
                       (float(v) for v in d)))
        out.update(zip(("iteration", "n", "bound", "features", "dual_evals"), (int(v) for v in i[:5])))
        out["status"] = STATUS[i[5]] if 0 <= i[5] < len(STATUS) else str(i[5])
        out["policy_flags"] = int(i[6])
        out["reason"] = reason
        return out

    def _names(self):
        names = (c_char_p * (self._dx + self._da))()
        with self._lock:  # the names point into the learner
            lib.pr_bind_learner_summary(self._h.ptr, (c_double * 7)(), (c_int * 7)(), names)
            return [v.decode(errors="surrogateescape") for v in names]

    @property
    def context_names(self) -> List[str]:
        """The context columns' names in a STATE file (`poolreps learner`)."""
        return self._names()[:self._dx]

    @property
    def action_names(self) -> List[str]:
        """The action columns' names in a STATE file."""
        return self._names()[self._dx:]

    # ---- saving ----

    def save(self) -> bytes:
        """The library's state bytes (what `poolreps learner` keeps in STATE)."""
        buf, n, err = _P(), c_size_t(), errbuf()
        check(self._call(lib.pr_learner_save, ctypes.byref(buf), ctypes.byref(n), err), err)
        try:
            return ctypes.string_at(buf, n.value)
        finally:
            lib.pr_bind_free(buf)

    @classmethod
    def load(cls, state: bytes, what: str = "state") -> "Learner":
        """A learner from save()'s bytes (or a STATE file's), with its stream."""
        self = cls.__new__(cls)
        self._restore(bytes(state), what)
        return self

    def _restore(self, state, what):
        # built aside: a failed load leaves a live learner and its stream as they were
        rng = rng_handle(lib.pr_bind_rng_new(0))
        err = errbuf()
        ptr = lib.pr_learner_load(state, len(state), what.encode(), rng.ptr, err)
        if not ptr:
            msg = err.value.decode(errors="replace")
            # another format version is the caller's error; what may say "version" too
            raise ValueError(msg) if msg.startswith(f"{what}: learner format version ") \
                else OSError(msg)
        if not hasattr(self, "_lock"):  # load and unpickling: no __init__
            self._lock = threading.Lock()
        with self._lock:  # the old learner goes before the stream it borrows
            self._h, self._rng = Handle(ptr, lib.pr_learner_free), rng
        self._dx = lib.pr_learner_context_dim(ptr)
        self._da = lib.pr_learner_action_dim(ptr)

    def __getstate__(self):
        return {"format": PICKLE_FORMAT, "state": self.save()}

    def __setstate__(self, st):
        if not isinstance(st, dict) or st.get("format") != PICKLE_FORMAT:
            raise ValueError(f"Learner: pickle format {st.get('format') if isinstance(st, dict) else st!r}, "
                             f"this package reads {PICKLE_FORMAT}")
        if not isinstance(st.get("state"), bytes):
            raise ValueError("Learner: a pickle without its state bytes")
        self._restore(st["state"], "pickle")

    def __repr__(self):
        return (f"Learner(context_dim={self._dx}, action_dim={self._da}, "
                f"iteration={self.iteration})")
