"""uw3p estimator: the paper's sequential convex loop (eqs 15-18) in cvxpy + Clarabel.

Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model".
"""

from .batch import BatchEstimate, estimate_batch
from .estimate import MODES, Estimate, Estimator, estimate, rrmse
from .lsq import estimate_least_squares
from .model import CHL_DERIVATIVE_FLOOR, WaterModel
from .precision import Precision, precision
from .subproblem import build_subproblem, compiled_subproblem

__all__ = ["BatchEstimate", "estimate_batch", "MODES", "Estimate", "Estimator", "estimate",
           "estimate_least_squares", "rrmse", "WaterModel", "CHL_DERIVATIVE_FLOOR",
           "build_subproblem", "compiled_subproblem", "Precision", "precision"]
