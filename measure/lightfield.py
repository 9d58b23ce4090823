"""Uneven light over the chart: a smooth achromatic light field, added only when the data need it.

Vignetting and a light gradient multiply every patch's reflected light by a factor f_p that is
the same in every channel (achromatic) and smooth over the chart. On synthetic photographs a
3 % gradient across the chart already gives chi^2/dof ~ 70 and biases C by ~25 %
(decision 0033-light-field), so the field is modelled -- but only as far as the data support it:

    f_p = 1 + a x_p + b y_p [+ c (x_p^2 + y_p^2 - mean)]

with (x_p, y_p) the patch centre in chart coordinates scaled to [-1, 1]. An achromatic f_p is
exactly a per-patch scaling of the reflectances, so for given field parameters the water is
fitted by the unchanged estimators on a chart with reflectances f_p R_p; the field parameters
minimise that fit's chi^2. They are found by Gauss-Newton on the profile (variable projection,
Kaufman 1975): the model is linear in the field, d M_cp / d theta_j = gain G_cp basis_pj =
(M_cp - s_c) basis_pj / f_p, and the step is the least-squares step of those columns after
projecting out the columns of the water, the gain and the backscatter (the one model function,
:meth:`sca.ChartModel.predict`, at the batch fit), halved until chi^2 falls. Each step costs one
batched fit, so a model takes a few fits, not the hundreds of a derivative-free search. The
nested models none < plane < plane+radial are compared by the likelihood-ratio test (the noise
is known, so Delta chi^2 is chi^2-distributed with the number of added parameters): a larger
model is taken only when its p-value is below ``LIGHT_FIELD_ALPHA``. The intervals of C and
a_CDOM are then conditional on the fitted field (decision 0033-light-field).
"""

from __future__ import annotations

import dataclasses

import numpy as np

import sca
from forward.water import resolve_water
from forward.errors import InputError

__all__ = ["FIELDS", "FIELD_FLOOR", "LIGHT_FIELD_ALPHA", "field_basis", "fit_light_field"]

#: The nested light-field models and their number of parameters.
FIELDS = {"none": 0, "plane": 2, "plane+radial": 3}
#: A larger light-field model is taken only when the likelihood-ratio test's p-value is below
#: this.
LIGHT_FIELD_ALPHA = 0.01
#: The field may not fall below this anywhere on the chart (a factor, not a physical limit).
FIELD_FLOOR = 0.2
#: Gauss-Newton stops when a step lowers chi^2 by less than this (absolute; chi^2 is O(dof))...
GN_FTOL = 1e-6
#: ... or moves no field coefficient (dimensionless) by more than this
GN_XTOL = 1e-8
#: Gauss-Newton's iteration cap per model, and the step halvings tried before it stops
GN_MAX_ITER = 50
GN_MAX_HALVINGS = 30


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


def _fit_at(theta, basis, M, sigma, setup, depth, distance, water, patch):
    """The free-gain batch fit of the water on the chart lit by the field ``theta``: (batch
    estimate, the set-up with the field, the field), or None where the field falls below
    :data:`FIELD_FLOOR`."""
    field = 1.0 + basis[:, :theta.size] @ theta
    if np.any(field < FIELD_FLOOR):
        return None
    fit_setup = _setup_with_field(setup, field)
    b = sca.estimate_batch(M[None], depth=depth, distance=distance, sigma=sigma,
                           setup=fit_setup, water=water, gain="free", intervals=False,
                           uncertain=patch, path_models=(resolve_water(water).path_model,))
    return b, fit_setup, field


def _step(fit, theta, basis, M, noise_sd, depth, distance, water):
    """The Gauss-Newton step of the field coefficients on the profile (variable projection):
    the least-squares step of the field's whitened columns after projecting out the active
    columns of the water (C, a_CDOM), the gain and the backscatter at the batch fit."""
    b, fit_setup, field = fit
    s = b.backscatter[0]
    pred = sca.ChartModel(fit_setup, water=water).predict(
        {"chl": b.chl, "cdom": b.cdom, "depth": depth, "distance": distance, "gain": b.gain,
         "backscatter": b.backscatter}, free=("chl", "cdom", "gain", "backscatter"),
        chl_floor=sca.CHL_DERIVATIVE_FLOOR)
    values, J = pred.values[0], pred.jacobian[0]
    m, n = M.shape
    active = np.concatenate([[b.chl[0] > 0, b.cdom[0] > 0, b.gain[0] > 0], s > 0])
    w = 1.0 / noise_sd.ravel()
    Jx = J[:, active] * w[:, None]
    # d M_cp / d theta_j = gain G_cp basis_pj = (M_cp - s_c) basis_pj / f_p
    signal = (values - np.repeat(s, n)).reshape(m, n) / field
    Jt = (signal[:, :, None] * basis[None, :, :theta.size]).reshape(m * n, -1) * w[:, None]
    r = (M.ravel() - values) * w
    Q = np.linalg.qr(Jx)[0] if Jx.shape[1] else np.zeros((m * n, 0))
    return np.linalg.lstsq(Jt - Q @ (Q.T @ Jt), r - Q @ (Q.T @ r), rcond=None)[0]


def _minimise(theta, basis, M, sigma, noise_sd, setup, depth, distance, water, patch):
    """Gauss-Newton from ``theta``, each step halved until the fit's chi^2 falls: (theta,
    chi^2)."""
    fit = _fit_at(theta, basis, M, sigma, setup, depth, distance, water, patch)
    if fit is None:
        raise InputError("theta", "the starting field falls below FIELD_FLOOR")
    chi2 = float(fit[0].objective[0])
    for _ in range(GN_MAX_ITER):
        delta = _step(fit, theta, basis, M, noise_sd, depth, distance, water)
        for _ in range(GN_MAX_HALVINGS):
            trial = _fit_at(theta + delta, basis, M, sigma, setup, depth, distance, water,
                            patch)
            if trial is not None and float(trial[0].objective[0]) <= chi2:
                break
            delta = delta / 2
        else:
            return theta, chi2
        gain_chi2 = chi2 - float(trial[0].objective[0])
        theta, fit, chi2 = theta + delta, trial, float(trial[0].objective[0])
        if gain_chi2 < GN_FTOL or np.max(np.abs(delta)) < GN_XTOL:
            break
    return theta, chi2


def fit_light_field(M, sigma, setup, depth, distance, water=None, alpha=LIGHT_FIELD_ALPHA,
                    models=tuple(FIELDS), uncertain=None):
    """Fit the nested light-field models and choose the smallest the data support.

    For each model of ``models`` in turn, the field coefficients minimise the chi^2 of the
    free-gain batch fit of the water on a chart with reflectances f_p R_p (Gauss-Newton on the
    profile, started at the previous model's coefficients); a larger model is chosen only while
    its likelihood-ratio test against the previous one has a p-value below ``alpha``.

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
    L. Kaufman, "A variable projection method for solving separable nonlinear least squares
    problems", BIT 15 (1975) 49-57 (the Gauss-Newton step of the field on the profile).
    """
    from scipy import special

    basis = field_basis()
    # the budget's per-patch term weighs the residuals; its nuisances are left at their
    # priors' centres (the search compares light fields)
    patch = {"patch": uncertain["patch"]} if uncertain and "patch" in uncertain else {}
    noise_sd = sca.budget.Budget(patch, {}, float(patch.get("patch", 0.0))).noise_sd(M, sigma)
    fits = {}
    prev = None
    for name in models:
        k = FIELDS[name]
        start = np.zeros(k)
        if prev is not None:
            start[:fits[prev]["theta"].size] = fits[prev]["theta"][:k]
        theta, chi2 = _minimise(start, basis, M, sigma, noise_sd, setup, depth, distance,
                                water, patch)
        p = None
        if prev is not None:
            dk = k - FIELDS[prev]
            p = float(special.chdtrc(dk, max(fits[prev]["chi2"] - chi2, 0.0)))
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
