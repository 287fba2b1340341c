"""poolreps from Python: the pool simulator, extremely randomized trees,
contextual REPS and the tree-LWR policy of *Feature Extraction for Policy
Search*, on numpy arrays, at the C library's speed.

    shoot(balls, actions, mode='event', set=None) -> dict      # poolreps shoot
    Forest(**keys).fit(X, y).predict(X) / .apply(X)           # poolreps forest
    reps(returns, features=None, epsilon=None, base=None)      # poolreps reps
    Policy(**keys).fit(S, A, w).mean_cov(S) / .sample / .log_prob   # poolreps policy
    PocketEnv(set=None)                                        # Gymnasium API

Keys are the CLI's (`poolreps --help`), given as a dict {'section.key':
value} (or, for Forest and Policy, as keyword arguments of their own
section); they are checked as --set checks them. Errors raise ValueError
(NumericalError, a ValueError, for numerical failures), OSError or
MemoryError with the library's one-line message.
"""
from ._lib import LIBRARY_PATH, LIBRARY_VERSION, NumericalError
from .core import REPS_FIELDS, Forest, Policy, reps, shoot
from .env import Bounds, PocketEnv

__version__ = "0.1.0"
__all__ = ["shoot", "reps", "Forest", "Policy", "PocketEnv", "Bounds", "NumericalError",
           "library_path", "library_version"]


def library_path():
    """The libpoolreps.so this package loaded."""
    return LIBRARY_PATH


def library_version():
    """The loaded library's version (git describe at its build)."""
    return LIBRARY_VERSION
