"""Uneven light over the chart: a smooth achromatic light field, added only when the data need it.

Vignetting and a light gradient multiply every patch's reflected light by a factor f_p that is
the same in every channel (achromatic) and smooth over the chart. On synthetic photographs a
3 % gradient across the chart already gives chi^2/dof ~ 70 and biases C by ~25 %
(DECISIONS.md), so the field is modelled -- but only as far as the data support it:

    f_p = 1 + a x_p + b y_p [+ c (x_p^2 + y_p^2 - mean)]

with (x_p, y_p) the patch centre in chart coordinates scaled to [-1, 1]. An achromatic f_p is
exactly a per-patch scaling of the reflectances, so for given field parameters the water is
fitted by the unchanged estimators on a chart with reflectances f_p R_p; the field parameters
are found by minimising that fit's chi^2 (Nelder-Mead on 2-3 parameters, the batched solver
inside). The nested models none < plane < plane+radial are compared by the likelihood-ratio
test (the noise is known, so Delta chi^2 is chi^2-distributed with the number of added
parameters): a larger model is taken only when its p-value is below ``LIGHT_FIELD_ALPHA``.
The intervals of C and a_CDOM are then conditional on the fitted field (DECISIONS.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import optimize, stats

import sca

__all__ = ["FIELDS", "LIGHT_FIELD_ALPHA", "field_basis", "fit_light_field"]

#: The nested light-field models and their number of parameters.
FIELDS = {"none": 0, "plane": 2, "plane+radial": 3}
#: A larger light-field model is taken only when the likelihood-ratio test's p-value is below
#: this.
LIGHT_FIELD_ALPHA = 0.01
#: The field may not fall below this anywhere on the chart (a factor, not a physical limit).
FIELD_FLOOR = 0.2


def field_basis(columns=6, rows=4) -> np.ndarray:
    """(n, 3): x, y and the centred x^2 + y^2 of every patch centre, chart coordinates in
    [-1, 1], ColorChecker order (row-major from patch 1)."""
    r, c = np.divmod(np.arange(columns * rows), columns)
    x = (c - (columns - 1) / 2) / ((columns - 1) / 2)
    y = (r - (rows - 1) / 2) / ((rows - 1) / 2)
    q = x * x + y * y
    return np.column_stack([x, y, q - q.mean()])


def _setup_with_field(setup, field):
    return dataclasses.replace(setup, reflectances=setup.reflectances * field[None, :])


def _chi2(theta, basis, M, sigma, setup, depth, distance, water):
    field = 1.0 + basis[:, :theta.size] @ theta
    if np.any(field < FIELD_FLOOR):
        return 1e300
    b = sca.estimate_batch(M[None], depth=depth, distance=distance, sigma=sigma,
                           setup=_setup_with_field(setup, field), water=water, gain="free",
                           intervals=False)
    return float(b.objective[0])


def fit_light_field(M, sigma, setup, depth, distance, water=None, alpha=LIGHT_FIELD_ALPHA,
                    models=tuple(FIELDS)):
    """Fit the nested light-field models to patch values ``M`` (3, 24, any units, noise
    ``sigma``); returns a dict: ``model`` (the chosen name), ``field`` (24,) its f_p,
    ``coefficients``, ``setup`` (reflectances scaled by f_p), and per model its chi^2 and the
    likelihood-ratio p-value against the previous model."""
    basis = field_basis()
    fits = {}
    prev = None
    for name in models:
        k = FIELDS[name]
        if k == 0:
            theta, chi2 = np.zeros(0), _chi2(np.zeros(0), basis, M, sigma, setup, depth,
                                             distance, water)
        else:
            start = np.zeros(k)
            if prev is not None:
                start[:fits[prev]["theta"].size] = fits[prev]["theta"]
            res = optimize.minimize(_chi2, start, args=(basis, M, sigma, setup, depth, distance,
                                                        water),
                                    method="Nelder-Mead",
                                    options=dict(xatol=1e-5, fatol=1e-4, maxiter=400 * k))
            theta, chi2 = res.x, float(res.fun)
        p = None
        if prev is not None:
            dk = k - FIELDS[prev]
            p = float(stats.chi2.sf(max(fits[prev]["chi2"] - chi2, 0.0), dk))
        fits[name] = {"theta": theta, "chi2": chi2, "p_value": p}
        prev = name
    chosen = models[0]
    for name in models[1:]:
        if fits[name]["p_value"] is not None and fits[name]["p_value"] < alpha:
            chosen = name
        else:
            break
    theta = fits[chosen]["theta"]
    field = 1.0 + basis[:, :theta.size] @ theta
    return {"model": chosen, "field": field, "coefficients": theta.tolist(),
            "setup": _setup_with_field(setup, field),
            "tests": {n: {"chi2": f["chi2"], "p_value": f["p_value"]} for n, f in fits.items()},
            "alpha": alpha}
