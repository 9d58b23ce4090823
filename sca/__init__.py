"""uw3p estimators: the paper's sequential convex loop (eqs 15-18) in cvxpy + Clarabel, the scipy
path, the batched variable-projection solver and the Cramér-Rao bound, all on one model function
(:meth:`sca.ChartModel.predict`).

Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model".
"""

from .batch import BatchEstimate, estimate_batch
from .bound import Precision, precision
from .budget import DEFAULT_UNCERTAIN
from .pathmodels import PATH_MODEL_DELTA
from .fitspec import FIXABLE, FREEABLE
from .loop import MODES, Estimator, estimate
from .lsq import estimate_least_squares
from .metrics import RRMSE_BANDS_NM, rrmse, rrmse_bands
from .model import CHL_DERIVATIVE_FLOOR, PARAMS, ChartModel, Prediction
from .results import Estimate
from .subproblem import build_subproblem, compiled_subproblem

__all__ = ["BatchEstimate", "estimate_batch", "MODES", "Estimate", "Estimator", "estimate",
           "estimate_least_squares", "rrmse", "rrmse_bands", "RRMSE_BANDS_NM", "ChartModel",
           "Prediction", "PARAMS", "FREEABLE", "FIXABLE", "CHL_DERIVATIVE_FLOOR",
           "build_subproblem", "compiled_subproblem", "Precision", "precision",
           "DEFAULT_UNCERTAIN", "PATH_MODEL_DELTA"]
