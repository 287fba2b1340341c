"""poolreps from Python: the pool simulator, extremely randomized trees,
contextual REPS and the tree-LWR policy of *Feature Extraction for Policy
Search*, on numpy arrays, at the C library's speed.

    shoot(balls, actions, mode='event', set=None) -> dict      # poolreps shoot
    Forest(**keys).fit(X, y).predict(X) / .apply(X)           # poolreps forest
    reps(returns, features=None, epsilon=None, base=None)      # poolreps reps
    Policy(**keys).fit(S, A, w).mean_cov(S) / .sample / .log_prob   # poolreps policy
    PocketEnv(set=None, render_mode=None, normalize_actions=False)  # Gymnasium API
    gymnasium.make_vec("poolreps/PocketEnv-v0", num_envs=N)   # PocketVectorEnv, batched
    poolreps.sb3.PocketVecEnv(N) / poolreps.video.RecordVideo(env, folder)  # SB3; clips
    Learner(context_dim, action_dim).ask(X) / .tell(X, A, R)   # poolreps learner

Keys are the CLI's (`poolreps --help`), given as a dict {'section.key':
value} (or, for Forest and Policy, as keyword arguments of their own
section); they are checked as --set checks them. Errors raise ValueError
(NumericalError, a ValueError, for numerical failures), OSError or
MemoryError with the library's one-line message. With Gymnasium installed,
importing the package registers the environment as "poolreps/PocketEnv-v0".
"""
from ._lib import LIBRARY_PATH, LIBRARY_VERSION, NumericalError
from .core import PICKLE_FORMAT, REPS_FIELDS, Forest, Policy, reps, shoot
from .env import ENV_ID, Bounds, PocketEnv
from .learner import Learner

__version__ = "0.1.0"
__all__ = ["shoot", "reps", "Forest", "Policy", "Learner", "PocketEnv", "Bounds", "NumericalError",
           "library_path", "library_version", "register_envs", "ENV_ID", "FOREST_FORMAT",
           "PICKLE_FORMAT"]


def library_path() -> str:
    """The libpoolreps.so this package loaded."""
    return LIBRARY_PATH


def library_version() -> str:
    """The loaded library's version (git describe at its build)."""
    return LIBRARY_VERSION


# the version of the forest text format this library writes and reads
FOREST_FORMAT = 1


def register_envs() -> None:
    """Register "poolreps/PocketEnv-v0" with Gymnasium (nothing without it;
    nothing when already registered). Gymnasium also calls this through the
    package's `gymnasium.envs` entry point."""
    try:
        import gymnasium
    except ImportError:
        return
    if ENV_ID not in gymnasium.registry:
        # the native vector env needs Gymnasium 1.x's VectorEnv (AutoresetMode)
        native = hasattr(gymnasium.vector, "AutoresetMode")
        gymnasium.register(id=ENV_ID, entry_point="poolreps.env:PocketEnv",
                           vector_entry_point="poolreps.vector:PocketVectorEnv" if native
                           else None)


register_envs()
