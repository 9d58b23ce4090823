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
from forward.water import resolve_water

__all__ = ["FIELDS", "LIGHT_FIELD_ALPHA", "FIELD_FLOOR", "field_basis", "fit_light_field"]

#: The nested light-field models and their number of parameters.
FIELDS = {"none": 0, "plane": 2, "plane+radial": 3}
#: A larger light-field model is taken only when the likelihood-ratio test's p-value is below
#: this.
LIGHT_FIELD_ALPHA = 0.01
#: The field may not fall below this anywhere on the chart (a factor, not a physical limit).
FIELD_FLOOR = 0.2
#: The chi^2 returned for a field below FIELD_FLOOR (Nelder-Mead then steps away from it)
INFEASIBLE_CHI2 = 1e300
#: Nelder-Mead's tolerances: on the field coefficients (dimensionless) and on chi^2
NM_XATOL = 1e-5
NM_FATOL = 1e-4
#: Nelder-Mead's iteration cap: this many per field parameter
NM_ITERATIONS_PER_PARAMETER = 400


def field_basis(columns=6, rows=4) -> np.ndarray:
    """The light field's basis at the patch centres.

    Parameters
    ----------
    columns, rows : int, optional
        The chart's patch grid (6 x 4 for the ColorChecker Classic).

    Returns
    -------
    numpy.ndarray, (columns * rows, 3)
        x, y and the centred x^2 + y^2 of every patch centre, chart coordinates scaled to
        [-1, 1] (dimensionless), ColorChecker order (row by row from patch 1).
    """
    r, c = np.divmod(np.arange(columns * rows), columns)
    x = (c - (columns - 1) / 2) / ((columns - 1) / 2)
    y = (r - (rows - 1) / 2) / ((rows - 1) / 2)
    q = x * x + y * y
    return np.column_stack([x, y, q - q.mean()])


def _setup_with_field(setup, field):
    return dataclasses.replace(setup, reflectances=setup.reflectances * field[None, :])


def _chi2(theta, basis, M, sigma, setup, depth, distance, water, uncertain=None):
    field = 1.0 + basis[:, :theta.size] @ theta
    if np.any(field < FIELD_FLOOR):
        return INFEASIBLE_CHI2
    # the budget's per-patch term weighs the residuals; its nuisances are left at their
    # priors' centres (the search compares light fields, each a few hundred fits)
    patch = {"patch": uncertain["patch"]} if uncertain and "patch" in uncertain else {}
    b = sca.estimate_batch(M[None], depth=depth, distance=distance, sigma=sigma,
                           setup=_setup_with_field(setup, field), water=water, gain="free",
                           intervals=False, uncertain=patch,
                           path_models=(resolve_water(water).path_model,))
    return float(b.objective[0])


def fit_light_field(M, sigma, setup, depth, distance, water=None, alpha=LIGHT_FIELD_ALPHA,
                    models=tuple(FIELDS), uncertain=None):
    """Fit the nested light-field models and choose the smallest the data support.

    For each model of ``models`` in turn, the field coefficients minimise the chi^2 of the
    free-gain batch fit of the water on a chart with reflectances f_p R_p (Nelder-Mead, started
    at the previous model's coefficients); a larger model is chosen only while its
    likelihood-ratio test against the previous one has a p-value below ``alpha``.

    Parameters
    ----------
    M : numpy.ndarray, (3, 24)
        Patch values (any units, e.g. raw DN above the black level).
    sigma : numpy.ndarray, (3, 24)
        Their standard errors, same units.
    setup : forward.ChartSetup
        Camera, illuminant and chart.
    depth, distance : float
        The chart's depth and the camera-to-chart distance, m.
    water : forward.Water, optional
        The water model (default the paper's).
    alpha : float, optional
        Significance level of the likelihood-ratio tests (default :data:`LIGHT_FIELD_ALPHA`).
    models : tuple of str, optional
        Names of :data:`FIELDS` in nesting order (default all: none, plane, plane+radial).
    uncertain : dict, optional
        The measurement's uncertainty budget (:mod:`sca.budget`): its per-patch term weighs
        the fits' residuals; its nuisance parameters are held at their priors' centres during
        the search (the final fit of :func:`measure.measure` profiles them). Default None:
        the photon noise alone.

    Returns
    -------
    dict
        ``model`` the chosen name; ``field`` (24,) its factors f_p (dimensionless);
        ``coefficients`` (a, b[, c]); ``setup`` the set-up with reflectances scaled by f_p;
        ``tests`` {model: {``chi2``, ``p_value`` against the previous model}}; ``alpha``.

    References
    ----------
    S. S. Wilks, "The large-sample distribution of the likelihood ratio for testing composite
    hypotheses", Ann. Math. Statist. 9(1), 60-62, 1938 (the likelihood-ratio test).
    J. A. Nelder and R. Mead, "A simplex method for function minimization", Comput. J. 7(4),
    308-313, 1965.
    """
    basis = field_basis()
    fits = {}
    prev = None
    for name in models:
        k = FIELDS[name]
        if k == 0:
            theta, chi2 = np.zeros(0), _chi2(np.zeros(0), basis, M, sigma, setup, depth,
                                             distance, water, uncertain)
        else:
            start = np.zeros(k)
            if prev is not None:
                start[:fits[prev]["theta"].size] = fits[prev]["theta"]
            res = optimize.minimize(_chi2, start, args=(basis, M, sigma, setup, depth, distance,
                                                        water, uncertain),
                                    method="Nelder-Mead",
                                    options=dict(xatol=NM_XATOL, fatol=NM_FATOL,
                                                 maxiter=NM_ITERATIONS_PER_PARAMETER * k))
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
