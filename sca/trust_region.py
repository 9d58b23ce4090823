"""The trust region of the safeguarded loop (Nocedal & Wright, Numerical Optimization, 2nd ed.,
Springer 2006, Algorithm 4.1, with eta = 0: any decrease is accepted), on the scaled unknowns."""

from __future__ import annotations

__all__ = ["TR_RADIUS0", "TR_ETA_SHRINK", "TR_ETA_GROW", "TR_SHRINK", "TR_GROW", "TR_AT_EDGE",
           "TR_RADIUS_MAX", "TR_RADIUS_MIN", "TR_COLLAPSE", "CONVERGED_PRED_FACTOR",
           "update_radius"]

#: initial radius Delta_0
TR_RADIUS0 = 1.0
#: rho = actual / predicted decrease below this: shrink (Alg. 4.1's 1/4)
TR_ETA_SHRINK = 0.25
#: rho above this, with the step at the boundary: grow (Alg. 4.1's 3/4)
TR_ETA_GROW = 0.75
#: shrink divisor (Alg. 4.1: Delta / 4) and growth factor (Alg. 4.1: 2 Delta)
TR_SHRINK, TR_GROW = 4.0, 2.0
#: a step of at least this fraction of the radius counts as "at the boundary" (||p|| = Delta)
TR_AT_EDGE = 0.9
#: largest radius (Alg. 4.1's Delta-hat) and the floor after a shrink
TR_RADIUS_MAX, TR_RADIUS_MIN = 1e4, 1e-14
#: after a rejected step the radius falls to ||step|| / 4; below this the loop gives up
TR_COLLAPSE = 1e-12
#: an accepted step converges when its decrease is below tol and the model predicted less than
#: this many times tol (relative to the objective)
CONVERGED_PRED_FACTOR = 10.0


def update_radius(radius, rho, step):
    """Trust-region radius after an accepted step (Alg. 4.1): grow when the model predicted
    the decrease well and the step reached the boundary, shrink when it did not.

    Parameters
    ----------
    radius : float
        Current radius (scaled units).
    rho : float
        Actual over predicted decrease.
    step : float
        Infinity norm of the accepted step (scaled units).

    Returns
    -------
    float
        The new radius.
    """
    if rho > TR_ETA_GROW and step >= TR_AT_EDGE * radius:
        return min(TR_GROW * radius, TR_RADIUS_MAX)
    if rho < TR_ETA_SHRINK:
        return max(radius / TR_SHRINK, TR_RADIUS_MIN)
    return radius
