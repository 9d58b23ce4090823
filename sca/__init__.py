"""uw3p estimators: the paper's sequential convex loop (eqs 15-18) in cvxpy + Clarabel, the scipy
path, the batched variable-projection solver and the Cramér-Rao bound, all on one model function
(:meth:`sca.ChartModel.predict`).

The public names are loaded on first use (PEP 562 module ``__getattr__``): ``import sca`` costs
nothing, and ``sca.estimate`` imports cvxpy, ``sca.estimate_batch`` numba, each only when asked
(the command line's start-up; decision 0007-start-up).

Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model".
"""

from __future__ import annotations

from forward.lazy import lazy_exports

#: Where each public name lives (submodule of ``sca``).
_HOME = {
    "BatchEstimate": "batch", "estimate_batch": "batch",
    "Precision": "bound", "precision": "bound",
    "DEFAULT_UNCERTAIN": "budget_defaults",
    "Design": "protocols", "design": "protocols",
    "PATH_MODEL_DELTA": "pathmodels",
    "FIXABLE": "fitspec", "FREEABLE": "fitspec",
    "MODES": "loop", "Estimator": "loop", "estimate": "loop",
    "JointEstimate": "joint", "estimate_joint": "joint",
    "estimate_least_squares": "lsq",
    "RRMSE_BANDS_NM": "metrics", "rrmse": "metrics", "rrmse_bands": "metrics",
    "CHL_DERIVATIVE_FLOOR": "model", "PARAMS": "model", "ChartModel": "model",
    "Prediction": "model",
    "Estimate": "results",
    "build_subproblem": "subproblem", "compiled_subproblem": "subproblem",
}
#: The public names: every name of :data:`_HOME`.
__all__ = list(_HOME)

__getattr__, __dir__ = lazy_exports(__name__, globals(), _HOME, __all__)
