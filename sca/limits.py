"""Numerical limits shared by every estimator."""

__all__ = ["EXACT_FIT", "MAX_RGB"]

#: Relative objective at which a fit is exact to rounding error: ||residual|| <= 1e-12 ||M||.
EXACT_FIT = 1e-24
#: Largest accepted measurement: model units are O(1), and larger values overflow the
#: objective in data units (its square).
MAX_RGB = 1e150
