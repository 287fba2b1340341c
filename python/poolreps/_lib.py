"""Loading libpoolreps.so, the C prototypes, errors, option sets and array checks.

Everything the package calls is declared in include/poolreps/bind.h (flat
arguments: pointers, integers, doubles, opaque handles) or is a plain public
function of the library (pr_config_set, pr_forest_predict_many, ...), so no C
struct layout is copied here.
"""
import atexit
import ctypes
import functools
import numbers
import os
import signal
import subprocess
import threading
import time
from ctypes import POINTER, c_char, c_char_p, c_double, c_int, c_long, c_size_t, c_ulong, c_void_p
from pathlib import Path

import numpy as np

SONAME = "libpoolreps.so.0"
ERRLEN = 512  # PR_ERRLEN
PR_OK, PR_EINVAL, PR_EIO, PR_ENUM, PR_ENOMEM, PR_EINTR = 0, -1, -2, -3, -4, -5


class NumericalError(ValueError):
    """A numerical failure reported by the library (a solver that failed, a
    shot past sim.max_events): the CLI's exit code 3."""


def _pkgconfig_dirs():
    """Library folders of an installed poolreps.pc (PKG_CONFIG_PATH and
    PKG_CONFIG_SYSROOT_DIR apply), or nothing."""
    for args in (["--libs-only-L"], ["--variable=libdir"]):
        try:
            out = subprocess.run(["pkg-config", *args, "poolreps"], capture_output=True,
                                 text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return
        if out.returncode == 0:
            for word in out.stdout.split():
                yield Path(word[2:] if word.startswith("-L") else word)


def _candidates():
    """Where to look, in order: $POOLREPS_LIB alone when set; the build of
    the checkout this package sits in; next to the package (`make python`
    puts a copy there, which `pip install ./python` carries along); the
    folders of an installed poolreps.pc; the dynamic loader's own search."""
    explicit = os.environ.get("POOLREPS_LIB")
    if explicit:
        yield Path(explicit)
        return
    here = Path(__file__).resolve().parent
    yield here.parent.parent / "build" / "rel" / SONAME
    yield here / SONAME
    for d in _pkgconfig_dirs():
        yield d / SONAME
    yield Path(SONAME)


# The shared libraries libpoolreps.so.0 links against, and the Debian 12
# packages that hold them (the wheel does not vendor them: docs/python.md).
# (tests/test_runtime_libs.py compares this with the library's NEEDED list.)
RUNTIME_PACKAGES = {
    "libgsl.so.27": "libgsl27", "libgslcblas.so.0": "libgslcblas0",
    "libglpk.so.40": "libglpk40", "libcsv.so.3": "libcsv3", "libinih.so.1": "libinih1",
    "libnlopt.so.0": "libnlopt0",
}


def missing_runtime(message):
    """The error for a library that exists but whose dependencies the loader
    cannot find (None when message says something else)."""
    import re
    m = re.search(r"(lib[\w.+-]+\.so[\w.]*): cannot open shared object file", message)
    if not m or m.group(1) == SONAME:
        return None
    pkgs = " ".join(RUNTIME_PACKAGES.values())
    return OSError(f"poolreps: {m.group(1)} is missing, which libpoolreps.so.0 needs: install "
                   f"the runtime libraries (Debian 12: apt-get install {pkgs}; see "
                   f"docs/python.md)")


def _load():
    tried = []
    for path in _candidates():
        if path.parent != Path(".") and not path.exists():
            tried.append(str(path))
            continue
        try:
            return ctypes.CDLL(str(path)), str(path)
        except OSError as e:
            err = missing_runtime(str(e))
            if err is not None:
                raise err from None
            tried.append(f"{path} ({e})")
    raise OSError("poolreps: libpoolreps.so.0 not found; build it with `make` (or `make "
                  "install`), or set POOLREPS_LIB. Tried: " + "; ".join(tried))


lib, LIBRARY_PATH = _load()

# ctypes releases the GIL around every call into a CDLL, so long calls let
# other Python threads run.
_P = c_void_p
_PROTOTYPES = {
    "pr_bind_init": (c_char_p, []),
    "pr_config_new": (_P, []),
    "pr_config_free": (None, [_P]),
    "pr_bind_config_ini": (_P, [_P, c_char_p]),
    "pr_bind_free": (None, [_P]),
    "pr_config_set": (c_int, [_P, c_char_p, c_char_p]),
    "pr_config_validate": (c_int, [_P, c_char_p]),
    "pr_config_get_double": (c_int, [_P, c_char_p, POINTER(c_double), c_char_p]),
    "pr_config_get_string": (c_int, [_P, c_char_p, c_char_p, c_size_t, c_char_p]),
    "pr_bind_shoot": (c_int, [_P, c_long, c_int, _P, _P, _P, _P, _P, _P, _P, _P, _P, c_char_p]),
    "pr_bind_shoot_range": (c_int, [_P, c_long, c_long, c_int, _P, _P, _P, _P, _P, _P, _P, _P,
                                    _P, c_char_p]),
    "pr_bind_shoot_params": (c_int, [_P, c_long, c_long, c_int, _P, _P, c_int, _P, _P, _P, _P,
                                     _P, _P, _P, _P, _P, c_int, c_char_p]),
    "pr_bind_uniforms_each": (None, [_P, c_long, c_int, _P]),
    "pr_bind_check_state": (c_int, [_P, _P, c_int, c_char_p]),
    "pr_bind_exp3_start_rng": (_P, [c_ulong, c_ulong]),
    "pr_bind_rng_size": (c_size_t, [_P]),
    "pr_bind_rng_state": (_P, [_P]),
    "pr_bind_trace": (c_int, [_P, c_int, _P, _P, POINTER(_P), POINTER(c_long), c_char_p]),
    "pr_forest_to_text": (c_int, [_P, _P, POINTER(_P), POINTER(c_size_t), c_char_p]),
    "pr_forest_load": (_P, [c_char_p, c_size_t, c_char_p, _P, c_char_p]),
    "pr_weights_check": (c_int, [_P, c_long, c_char_p, POINTER(c_long), c_char_p]),
    "pr_config_key_listed": (c_int, [c_char_p, c_char_p]),
    "pr_bind_policy_rng_new": (_P, [c_ulong]),
    "pr_bind_policy_sample_rng": (c_int, [_P, c_long, _P, c_int, _P, _P, _P, c_char_p]),
    "pr_bind_starts": (c_int, [_P, _P, c_long, _P, c_char_p]),
    "pr_bind_starts_each": (c_int, [_P, _P, c_long, _P, c_char_p]),
    "pr_bind_rng_new": (_P, [c_ulong]),
    "pr_bind_rng_free": (None, [_P]),
    "pr_bind_forest_fit": (c_int, [_P, c_int, c_int, c_int, _P, _P, _P, POINTER(_P), c_char_p]),
    "pr_bind_forest_apply": (c_int, [_P, c_long, _P, _P, c_char_p]),
    "pr_forest_free": (None, [_P]),
    "pr_forest_predict_many": (None, [_P, _P, c_int, _P]),
    "pr_forest_ntrees": (c_int, [_P]),
    "pr_forest_nleaves": (c_int, [_P]),
    "pr_forest_dx": (c_int, [_P]),
    "pr_forest_dy": (c_int, [_P]),
    "pr_forest_tree_leaf0": (c_int, [_P, c_int]),
    "pr_bind_reps": (c_int, [_P, c_int, c_int, _P, _P, _P, _P, _P, _P, POINTER(_P), c_char_p]),
    "pr_bind_reps_field": (c_char_p, [c_int, POINTER(c_char)]),
    "pr_bind_reps_value": (c_double, [_P, c_int]),
    "pr_bind_reps_text": (c_char_p, [_P, c_int]),
    "pr_bind_reps_p": (_P, [_P]),
    "pr_bind_reps_theta": (_P, [_P]),
    "pr_reps_result_free": (None, [_P]),
    "pr_bind_policy_fit": (c_int, [_P, c_int, c_int, c_int, c_int, _P, _P, _P, _P, POINTER(_P),
                                   c_char_p]),
    "pr_bind_policy_eval": (c_int, [_P, c_long, _P, _P, _P, _P, c_char_p]),
    "pr_bind_policy_sample": (c_int, [_P, c_long, _P, c_int, c_ulong, _P, _P, c_char_p]),
    "pr_bind_policy_logpdf": (c_int, [_P, c_long, _P, _P, _P, _P, c_char_p]),
    "pr_policy_free": (None, [_P]),
    "pr_policy_ds": (c_int, [_P]),
    "pr_policy_da": (c_int, [_P]),
}
for _name, (_res, _args) in _PROTOTYPES.items():
    _f = getattr(lib, _name)
    _f.restype = _res
    _f.argtypes = _args

LIBRARY_VERSION = lib.pr_bind_init().decode()


def errbuf():
    """A fresh message buffer per call: no buffer is shared between threads."""
    return ctypes.create_string_buffer(ERRLEN)


def check(rc, err):
    """Raise the exception for a library status, with the library's message."""
    if rc == PR_OK:
        return
    msg = err.value.decode(errors="replace")
    if rc == PR_ENOMEM:
        raise MemoryError(msg)
    if rc == PR_EIO:
        raise OSError(msg)
    if rc == PR_ENUM:
        raise NumericalError(msg)
    if rc == PR_EINTR:
        raise KeyboardInterrupt(msg)
    raise ValueError(msg)


class Handle:
    """Owns one C object and frees it with the library's _free when the last
    reference goes. A method takes a local reference for the length of its
    call, so replacing an object's handle (a new fit) while another thread
    still uses the old one is safe."""

    __slots__ = ("ptr", "_free", "meta")

    def __init__(self, ptr, free, meta=None):
        self.ptr = ptr
        self._free = free
        self.meta = meta  # facts of the fit that methods need (e.g. y was 1-D)

    def __del__(self):
        # getattr: a Handle whose __init__ never ran (or ran half-way) owns nothing
        ptr, free = getattr(self, "ptr", None), getattr(self, "_free", None)
        if ptr and free:
            free(ptr)
            self.ptr = None

    def __reduce__(self):
        raise TypeError("a C object of poolreps cannot be pickled by itself; pickle the "
                        "Forest, Policy or PocketEnv that owns it")

    def __repr__(self):
        return f"<poolreps C object at {self.ptr:#x}>" if self.ptr else "<poolreps C object (freed)>"


def rng_handle(ptr):
    """A Handle for a gsl_rng the library made (MemoryError for NULL)."""
    if not ptr:
        raise MemoryError("rng: out of memory")
    return Handle(ptr, lib.pr_bind_rng_free)


def rng_state(h):
    """The bytes of a generator's state (it continues from them exactly)."""
    return ctypes.string_at(lib.pr_bind_rng_state(h.ptr), lib.pr_bind_rng_size(h.ptr))


def rng_from_state(state):
    """A generator set to the state rng_state returned."""
    h = rng_handle(lib.pr_bind_rng_new(0))
    if len(state) != lib.pr_bind_rng_size(h.ptr):
        raise ValueError(f"rng state: {len(state)} bytes, this library's generator has "
                         f"{lib.pr_bind_rng_size(h.ptr)}")
    ctypes.memmove(lib.pr_bind_rng_state(h.ptr), state, len(state))
    return h


# One pickle format for PocketEnv and PocketVectorEnv: a dict with the format,
# the env's own fields, then gymnasium's np_random and its seed.
def pickle_state(env, **fields):
    """The dict an env's __getstate__ returns, its fields in the given order."""
    return {"format": 1, **fields, "np_random": getattr(env, "_np_random", None),
            "np_random_seed": getattr(env, "_np_random_seed", None)}


def check_pickle(cls, st):
    """ValueError unless st is a pickle_state of the format this version reads."""
    if not isinstance(st, dict) or st.get("format") != 1:
        v = st.get("format") if isinstance(st, dict) else None
        raise ValueError(f"{cls}: pickle format version {v}, this poolreps reads version 1")


def restore_np_random(env, st):
    """gymnasium's generator and seed from a pickle_state, if it had one."""
    if st["np_random"] is not None:
        env._np_random = st["np_random"]
        env._np_random_seed = st["np_random_seed"]


# The library's flag its row loops poll (the CLI's signal handler sets it).
_INTERRUPTED = c_int.in_dll(lib, "pr_interrupted")
# the end (an Event) of each worker told to stop and still finishing its row
_STOPPING = []


def settle():
    """Wait for the workers an interrupt left finishing their row: until they
    end, the library's flag would stop the next call too."""
    while _STOPPING:
        _STOPPING.pop().wait()


# and before the interpreter exits: a worker still in the library when the
# process's exit handlers free the libraries' state (OpenBLAS's buffers)
# crashed it (a segfault after a KeyboardInterrupt ended the script)
atexit.register(settle)


def interruptible(call, *keep):
    """call() (a library call that polls pr_interrupted per row) in a worker
    thread, the caller waiting in slices of 50 ms: Python runs its signal
    handlers only between bytecodes, so a KeyboardInterrupt (or a SIGTERM
    handler's exception) reaches the caller within that slice whatever a
    row costs. The worker is then told to stop (pr_interrupted) and ends
    after its current row, in the background; the flag is cleared when it
    has. keep: what the call writes into or reads (arrays, buffers), held
    until it ends. Off the main thread, which gets no signals, call() runs
    directly."""
    if threading.current_thread() is not threading.main_thread():
        return call()
    settle()
    box, lock, ended = {"done": False, "stop": False}, threading.Lock(), threading.Event()

    def work(keep=keep):
        try:
            box["rc"] = call()
        except BaseException as e:  # pragma: no cover (ctypes calls do not raise)
            box["exc"] = e
        finally:
            with lock:  # whoever comes second clears the flag: it never outlives the call
                box["done"] = True
                if box["stop"]:
                    _INTERRUPTED.value = 0
            ended.set()
    # an Event, not Thread.join: a join cut short by KeyboardInterrupt may
    # report a running thread as ended
    threading.Thread(target=work, name="poolreps-call", daemon=True).start()
    try:
        while not ended.wait(0.05):
            pass
    except BaseException:
        with lock:
            if not box["done"]:
                box["stop"] = True
                _INTERRUPTED.value = signal.SIGINT
                _STOPPING.append(ended)
        raise
    if "exc" in box:
        raise box["exc"]
    return box["rc"]


# Long calls go to the library in pieces of this many rows, and Python
# handles its signals between them: Ctrl-C stops a long batch within a
# piece's time (a few milliseconds) instead of at its end.
CHUNK_ROWS = 8192


def interruptible_call(fn, *args, keep=()):
    """fn(*args), a library call that cannot be cut into pieces (a fit, a
    REPS solve) and polls pr_interrupted in its loops, as interruptible()
    runs one: Ctrl-C reaches the caller at once. keep: the objects behind
    the addresses in args (arrays, the configuration), held until the call
    ends: an interrupted caller unwinds while the worker still reads them."""
    return interruptible(lambda: fn(*args), *args, *keep)


def chunks(n, rows=CHUNK_ROWS):
    """(lo, hi) ranges covering 0..n-1 in pieces."""
    return ((lo, min(n, lo + rows)) for lo in range(0, n, rows))


# A row-wise call whose bound on its work (rows x the most elementary steps
# a row can take: node visits, multiply-adds) is below this runs on the
# caller's thread, a few milliseconds at most; a longer one in a worker.
DIRECT_WORK = 2e6
# a worker's pieces grow (from one row) to about this long each
PIECE_SECONDS = 0.02


def rows_interruptibly(n, piece, row_work, most=CHUNK_ROWS):
    """piece(lo, hi) over the rows 0..n-1 (a library call per piece that
    does not poll pr_interrupted), with Ctrl-C honoured by time, whatever a
    row costs. row_work bounds a row's work: a call of at most DIRECT_WORK
    runs here, in pieces of at most `most` rows. A longer one runs in a
    worker (interruptible(): the caller gets KeyboardInterrupt within 50 ms),
    in pieces sized by their time, from one row up to about PIECE_SECONDS:
    told to stop, the worker ends after its current piece."""
    if n * row_work <= DIRECT_WORK or threading.current_thread() is not threading.main_thread():
        for lo, hi in chunks(n, most):
            piece(lo, hi)
        return

    def call():
        lo, rows = 0, 1
        while lo < n and not _INTERRUPTED.value:
            hi = min(n, lo + rows)
            t = time.perf_counter()
            piece(lo, hi)
            took = time.perf_counter() - t
            rows = max(1, min(4 * rows, most, int(rows * PIECE_SECONDS / max(took, 1e-9))))
            lo = hi
    interruptible(call)


def seed_value(name, seed):
    """An integer seed in 0..2**32-1; ValueError for anything else (a float
    such as 1.5, a bool, a negative number)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise ValueError(f"{name}: must be an integer in 0..4294967295 (got {seed!r})")
    if not 0 <= int(seed) <= 4294967295:
        raise ValueError(f"{name}: must be an integer in 0..4294967295 (got {seed})")
    return int(seed)


def env_seed(name, seed):
    """An environment's seed: any integer >= 0 (what Gymnasium accepts),
    wrapped to 0..2**32-1, so that a vector env's seed + i works at the top
    of the range; ValueError for anything else."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"{name}: must be an integer >= 0 (got {seed!r})")
    return int(seed) % 2**32


def options(opts, known):
    """A reset's options as a dict; ValueError for a key not in known (a
    typo must not be ignored)."""
    opts = dict(opts or {})
    unknown = sorted(set(opts) - set(known), key=str)
    if unknown:
        raise ValueError(f"options: unknown key {unknown[0]!r} (known: "
                         f"{', '.join(repr(k) for k in sorted(known))})")
    return opts


def addr(a):
    """The data address of a C-contiguous numpy array (or None)."""
    return None if a is None else a.ctypes.data


# ---- keys -------------------------------------------------------------------

def _format(key, v):
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        raise ValueError(f"{key}: a number or text is expected, not a bool")
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))
    if isinstance(v, (list, tuple, np.ndarray)):
        return ",".join(_format(key, x) for x in v)
    raise ValueError(f"{key}: cannot use a {type(v).__name__} as a value")


def weights(name, w, what):
    """w (n,) as the library checks weights (pr_weights_check, the CLI's
    check too): ValueError "NAME[i]: WHAT must be >= 0 ..." or "NAME: ..."."""
    bad = c_long(-1)
    err = errbuf()
    if lib.pr_weights_check(addr(w), w.shape[0], what.encode(), ctypes.byref(bad), err):
        at = f"[{bad.value}]" if bad.value >= 0 else ""
        raise ValueError(f"{name}{at}: {err.value.decode(errors='replace')}")
    return w


def assignments(keys, section=None, applies=None):
    """'section.key=value' strings, in order, from a dict. Without a dot a
    key belongs to `section` ('trees' -> 'forest.trees'); 'seed' is
    experiment.seed. applies: the keys the command of `section` reads (its
    CLI list, "forest.,experiment.seed"); another is refused as the CLI's
    --set refuses it, since it would be ignored."""
    out = []
    for k, v in (keys or {}).items():
        if not isinstance(k, str):
            raise ValueError(f"{k!r}: keys are 'section.key' strings")
        if "." not in k:
            if k == "seed":
                k = "experiment.seed"
            elif section:
                k = f"{section}.{k}"
        if applies is not None and not lib.pr_config_key_listed(applies.encode(), k.strip().encode()):
            raise ValueError(f"{section}: --set {k.strip()} does not apply (see poolreps {section} --help)")
        out.append(f"{k}={_format(k, v)}")
    return tuple(out)


class Config:
    """A pr_config: defaults, then each assignment through pr_config_set
    (the --set path, with its checks and one-line messages), then
    pr_config_validate. Read-only once built, so it may be shared."""

    def __init__(self, sets):
        ptr = lib.pr_config_new()
        if not ptr:
            raise MemoryError("config: out of memory")
        self._h = Handle(ptr, lib.pr_config_free)
        err = errbuf()
        for a in sets:
            if "\0" in a:
                raise ValueError(f"--set {a.split(chr(0))[0]}: NUL character")
            check(lib.pr_config_set(ptr, a.encode(), err), err)
        check(lib.pr_config_validate(ptr, err), err)
        self._ini = None

    @property
    def ptr(self):
        return self._h.ptr

    def values(self):
        """{'section.key': 'value text'} for every key (the effective configuration)."""
        if self._ini is None:
            err = errbuf()
            text = lib.pr_bind_config_ini(self.ptr, err)
            if not text:
                check(PR_ENOMEM, err)
            try:
                ini = ctypes.string_at(text).decode()
            finally:
                lib.pr_bind_free(text)
            section, values = "", {}
            for line in ini.splitlines():
                line = line.strip()
                if line.startswith("["):
                    section = line[1:-1]
                elif "=" in line:
                    k, v = line.split("=", 1)
                    values[f"{section}.{k.strip()}"] = v.strip()
            self._ini = values
        return self._ini

    def number(self, key):
        """A number key's value (pr_config_get_double)."""
        v, err = c_double(), errbuf()
        check(lib.pr_config_get_double(self.ptr, key.encode(), ctypes.byref(v), err), err)
        return v.value

    def text(self, key):
        """Any key's value as the parameter file writes it (pr_config_get_string)."""
        buf, err = ctypes.create_string_buffer(4096), errbuf()
        check(lib.pr_config_get_string(self.ptr, key.encode(), buf, len(buf), err), err)
        return buf.value.decode()


@functools.lru_cache(maxsize=64)
def config(sets):
    """The Config for a tuple of assignments (cached: building one is cheap,
    but a step of an environment should not rebuild it)."""
    return Config(sets)


# ---- arrays -----------------------------------------------------------------

def array(name, a, ndim, cols=None, rows=None, allow_empty=False, finite=True):
    """a as a C-contiguous float64 array of ndim dimensions, copied only when
    its dtype or layout requires; ValueError for another shape, a dtype that
    is not real numbers, or (with finite) a value that is not finite."""
    try:
        arr = np.asarray(a)
    except Exception as e:  # e.g. ragged nested lists
        raise ValueError(f"{name}: not an array ({e})") from None
    if arr.dtype.kind not in "iuf":
        raise ValueError(f"{name}: expected real numbers, got dtype {arr.dtype}")
    if arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if cols is not None and arr.shape[1] != cols:
        raise ValueError(f"{name}: expected {cols} columns, got shape {arr.shape}")
    if rows is not None and arr.shape[0] != rows:
        raise ValueError(f"{name}: expected {rows} rows, got shape {arr.shape}")
    if not allow_empty and arr.size == 0:
        raise ValueError(f"{name}: empty array of shape {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    if finite and not np.isfinite(arr).all():
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise ValueError(f"{name}{list(bad)}: not a finite number ({arr[bad]})")
    return arr


INT_MAX = 2**31 - 1
C_LONG = np.dtype(f"i{ctypes.sizeof(c_long)}")


def count(name, n):
    if n > INT_MAX:
        raise ValueError(f"{name}: {n} rows, at most {INT_MAX}")
    return n
