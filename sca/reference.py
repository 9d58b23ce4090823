"""The surface reference shot: the light at the site measured from a chart photographed in air.

A photo underwater measures the path's optical depth; at 443 and 490 nm what limits it is the
colour of the surface daylight, which the default budget carries as a prior of 30 mired about
the illuminant given (:data:`sca.budget_defaults.DEFAULT_UNCERTAIN` 'daylight'). A chart
photographed in air at the site, under the same sky shortly before or after the dive, sees that
light unfiltered. :func:`measure_light` fits its colour with the one model function
(:meth:`sca.ChartModel.predict` at depth = distance = 0: no water): the daylight's shift
(mired, relative to the setup's ``daylight_cct``) free, the exposure gain free, and the
camera's channel balance and curves under their own priors (a profile of another day: 1 %,
1 nm), the per-patch term in the noise, so that the fit does not mistake the balance for the
light. The sky changes between the shot and the dive: :func:`sky_sd` adds an sd per the time
between them. :meth:`Light.prior` is the budget's measured prior ``{"centre", "sd", ...}``
(:func:`sca.budget.prior_of`) which every estimator reads through ``uncertain=``:
:func:`with_reference` is the one place a reference replaces the default's daylight prior.

References
----------
J. Hernández-Andrés, J. Romero, J. L. Nieves and R. L. Lee, "Color and spectral analysis of
daylight in southern Europe", J. Opt. Soc. Am. A 18 (2001) 1325-1335 (the spread of daylight's
CCT: the default prior). Decision 0069-reference-shot (the sky's change, its numbers).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from forward.errors import InputError
from forward.imaging import ChartSetup

from .budget import parse_sd
from .budget_defaults import DEFAULT_UNCERTAIN

__all__ = ["SKY_SD", "SKY_MINUTES", "REFERENCE_MINUTES", "CONFLICT_FLAG", "Light", "Bracket",
           "bracket", "conflict_of", "measure_light", "planned", "sky_sd", "with_reference",
           "PLANNED_FIT_SD", "PER_CHART", "REFERENCE_PATCH", "check_daylight",
           "patch_response"]

#: The sky's change reaches the default prior's spread (mired) ...
SKY_SD = float(DEFAULT_UNCERTAIN["daylight"])
#: ... after this many minutes between the reference shot and the dive, growing as a random
#: walk before (sd = SKY_SD sqrt(minutes / SKY_MINUTES)): 10 min 8.7 mired, 30 min 15 mired
#: (decision 0069-reference-shot).
SKY_MINUTES = 120.0
#: The time between the reference shot and the dive where none is given, minutes.
REFERENCE_MINUTES = 10.0
#: The sd (mired) of the light a planned reference shot will measure (:func:`planned`): the
#: fit's sd in air, 1.8 mired in simulation (decision 0069-reference-shot), rounded up
#: (decision 0075-design-reference-shot).
PLANNED_FIT_SD = 2.0
#: The flag (:data:`sca.assess.BLOCKING`) of an estimate whose budget holds reference shots that
#: disagree beyond their sds (:func:`bracket`: chi^2 p below :data:`sca.assess.CONFLICT_P`).
CONFLICT_FLAG = "reference-conflict"
#: The nuisances of the camera held to their priors in the fit in air.
CAMERA_PRIORS = ("balance", "camera_shift")
#: The per-patch term (relative) that the chart's response measured in air leaves: what the
#: shot cannot see, the part of the curves' and the spectra's errors that the water's spectral
#: filtering changes (measured on the independent renderer: decision
#: 0079-reference-patch-response). The shot's own photon noise adds to it
#: (:meth:`Light.patch_sd`).
REFERENCE_PATCH = 0.002


def sky_sd(minutes) -> float:
    """The sd (mired) of the daylight's change over ``minutes`` between the reference shot and
    the dive: :data:`SKY_SD` sqrt(minutes / :data:`SKY_MINUTES`), at most :data:`SKY_SD`.

    Raises
    ------
    forward.errors.InputError
        Naming 'minutes' for a negative or non-finite value.
    """
    try:
        t = float(minutes)
    except (TypeError, ValueError):
        t = float("nan")
    if isinstance(minutes, bool) or not np.isfinite(t) or t < 0:
        raise InputError("minutes", f"the time between the reference shot and the dive must be "
                         f"a number of minutes >= 0, got {minutes!r}")
    return float(min(SKY_SD, SKY_SD * np.sqrt(t / SKY_MINUTES)))


@dataclass(frozen=True)
class Light:
    """The surface light measured by a reference shot.

    Attributes
    ----------
    centre : float
        The daylight's colour shift from the set-up's illuminant, mired (the model's
        'daylight' parameter).
    sd : float
        Its standard deviation, mired (the fit's: photon noise, per-patch term, the camera's
        priors).
    reference_cct : float
        The illuminant's temperature the shift refers to, K.
    chi2_dof : float
        Reduced chi^2 of the fit (with the per-patch term in the noise).
    factors : ndarray, (m, n), or None
        The chart's response measured in air (:func:`patch_response`): each (channel, patch)
        value over the model's at the measured light, the gain fitted; None where the shot
        measured the light only (a value clipped or left out).
    factors_sd : ndarray, (m, n), or None
        Their relative sds (the shot's photon noise).
    """

    centre: float
    sd: float
    reference_cct: float
    chi2_dof: float
    factors: np.ndarray | None = None
    factors_sd: np.ndarray | None = None

    @property
    def cct(self) -> float:
        """The measured light's correlated colour temperature, K."""
        return 1e6 / (1e6 / self.reference_cct + self.centre)

    def to_dict(self) -> dict:
        """Plain numbers (what a profile records)."""
        out = {"centre_mired": self.centre, "sd_mired": self.sd, "cct_K": self.cct,
               "reference_cct_K": self.reference_cct, "chi2_dof": self.chi2_dof}
        if self.factors is not None:
            out |= {"factors": np.asarray(self.factors).tolist(),
                    "factors_sd": np.asarray(self.factors_sd).tolist()}
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "Light":
        """The inverse of :meth:`to_dict`."""
        f, fsd = (None if d.get(k) is None else np.asarray(d[k], float)
                  for k in ("factors", "factors_sd"))
        return cls(float(d["centre_mired"]), float(d["sd_mired"]), float(d["reference_cct_K"]),
                   float(d.get("chi2_dof", float("nan"))), f, fsd)

    def patch_sd(self) -> float:
        """The per-patch term left with this shot's response: :data:`REFERENCE_PATCH` and the
        rms of the factors' relative sds in quadrature (decision
        0079-reference-patch-response); NaN without factors."""
        if self.factors is None:
            return float("nan")
        return float(np.hypot(REFERENCE_PATCH, np.sqrt(np.mean(np.square(self.factors_sd)))))

    def prior(self, minutes=REFERENCE_MINUTES, source: str = "") -> dict:
        """The budget's measured 'daylight' prior: centre, sd = sqrt(sd_fit^2 + sky_sd^2)
        (:func:`sky_sd` of ``minutes``) and the record of where it comes from."""
        sky = sky_sd(minutes)
        return {"centre": self.centre, "sd": float(np.hypot(self.sd, sky)), "sd_fit": self.sd,
                "sd_sky": sky, "minutes": float(minutes),
                "source": source or "measured at the site by a reference shot"}


@dataclass(frozen=True)
class Bracket:
    """Two reference shots bracketing the dive (one before, one after), combined
    (:func:`bracket`).

    Attributes
    ----------
    lights : tuple of Light
        The two shots.
    minutes : tuple of float
        Each shot's time from the dive, minutes.
    chi2, p : float
        Their disagreement: (centre_a - centre_b)^2 / (v_a + v_b), v = sd_fit^2 + sd_sky^2
        (:func:`sky_sd`), and its chi^2_1 p-value.
    """

    lights: tuple
    minutes: tuple
    chi2: float
    p: float

    @property
    def conflict(self) -> bool:
        """The shots disagree beyond their sds: p below :data:`sca.assess.CONFLICT_P`."""
        from .assess import CONFLICT_P

        return self.p < CONFLICT_P

    def prior(self, source: str = "") -> dict:
        """The budget's measured 'daylight' prior of both shots: centre the inverse-variance
        mean of the shots' priors (:meth:`Light.prior`; weights ~ 1/minutes when the fits'
        sds are small: the Brownian bridge's time-weighted mean), sd theirs times
        max(1, sqrt(chi2)) (their disagreement), never below the nearer shot's sky sd; the
        record keeps both shots, the chi^2, its p and ``conflict``."""
        one = [lt.prior(t) for lt, t in zip(self.lights, self.minutes)]
        w = np.array([1.0 / p["sd"] ** 2 for p in one])
        centre = float(np.dot(w, [p["centre"] for p in one]) / w.sum())
        sd = max(float(np.sqrt(max(1.0, self.chi2) / w.sum())), sky_sd(min(self.minutes)))
        return {"centre": centre, "sd": sd, "shots": one, "chi2": self.chi2, "p": self.p,
                "conflict": self.conflict, "minutes": float(min(self.minutes)),
                "sd_fit": float(np.sqrt(1.0 / sum(1.0 / lt.sd ** 2 for lt in self.lights))),
                "sd_sky": sky_sd(min(self.minutes)),
                "source": source or "measured at the site by reference shots before and "
                "after the dive"}


def bracket(lights, minutes) -> Bracket:
    """Two reference shots, one before and one after the dive, ``minutes`` from it each:
    their difference tested against their sds and the sky's change (decision
    0074-reference-bracket).

    Raises
    ------
    forward.errors.InputError
        Naming 'lights' unless two lights and two times are given; 'minutes' as
        :func:`sky_sd`.
    """
    from scipy.special import chdtrc

    lights, minutes = tuple(lights), tuple(minutes)
    if len(lights) != 2 or len(minutes) != 2:
        raise InputError("lights", f"a bracket is two reference shots (before and after the "
                         f"dive), got {len(lights)} shots and {len(minutes)} times")
    [sky_sd(t) for t in minutes]  # each a number of minutes >= 0
    minutes = tuple(float(t) for t in minutes)
    v = [lt.sd ** 2 + sky_sd(t) ** 2 for lt, t in zip(lights, minutes)]
    chi2 = float((lights[0].centre - lights[1].centre) ** 2 / sum(v))
    return Bracket(lights, minutes, chi2, float(chdtrc(1, chi2)))


def conflict_of(uncertain) -> bool:
    """Whether ``uncertain`` holds a measured prior whose reference shots disagree
    (:attr:`Bracket.conflict`, recorded as ``"conflict"`` in the prior)."""
    return any(isinstance(v, dict) and bool(v.get("conflict")) for v in (uncertain or {}).values())


def planned(uncertain, minutes=REFERENCE_MINUTES) -> dict | None:
    """``uncertain`` as a design plans it with a reference shot ``minutes`` from the dive: the
    daylight's prior centred where the budget's is, its sd sqrt(:data:`PLANNED_FIT_SD`^2 +
    :func:`sky_sd`^2) (:func:`with_reference` of a :class:`Light` of that sd)."""
    return with_reference(uncertain, Light(0.0, PLANNED_FIT_SD, float("nan"), float("nan")),
                          minutes, "a reference shot planned")


#: The entries of a measured prior that a batch holds chart by chart.
PER_CHART = ("centre", "sd", "sd_fit")


def with_reference(uncertain, light, minutes=REFERENCE_MINUTES,
                   source: str = "", response: bool = False) -> dict | None:
    """``uncertain`` (None: the default budget) with its 'daylight' prior replaced by the
    reference's: a :class:`Light`'s (:meth:`Light.prior` at ``minutes``), a
    :class:`Bracket`'s (:meth:`Bracket.prior`, its own times), or a sequence of lights, one per
    chart of a batch (each chart its own prior, one fit of them all); ``uncertain`` as given
    without a reference or for the paper's exact model ``{}``.

    With ``response`` (off by default), where the shots measured the chart's response
    (:attr:`Light.factors`), the budget carries it too: ``'response'`` the factors ((m, n); a bracket's two inverse-variance averaged; one set
    per chart of a sequence) that every estimator's model applies to the direct signal
    (:meth:`sca.budget.Budget.model`), and ``'patch'`` lowered to what the shot cannot see
    (:meth:`Light.patch_sd`; the largest of the charts'; never above the budget's own). It is
    off by default: in HONESTY.md's reference world its intervals are too narrow (decision
    0079-reference-patch-response), where the light alone covers every quantity."""
    if light is None or uncertain == {}:
        return uncertain
    base = dict(DEFAULT_UNCERTAIN if uncertain is None else uncertain)
    if isinstance(light, Bracket):
        return base | {"daylight": light.prior(source)} | _response_entries(
            base, [_averaged(light.lights)] if response else [])
    if isinstance(light, Light):
        return base | {"daylight": light.prior(minutes, source)} | _response_entries(
            base, [light] if response else [])
    each = [lt.prior(minutes, source) for lt in light]
    return base | {"daylight": {k: np.array([e[k] for e in each]) if k in PER_CHART else each[0][k]
                                for k in each[0]}} | _response_entries(
        base, list(light) if response else [])


def _averaged(lights) -> Light:
    """The shots' factors averaged with inverse-variance weights (their light: the first's;
    the bracket's prior is :meth:`Bracket.prior`); no factors unless every shot has them."""
    if any(lt.factors is None for lt in lights):
        return dataclasses.replace(lights[0], factors=None, factors_sd=None)
    w = np.array([1.0 / np.square(lt.factors_sd) for lt in lights])
    f = np.sum(w * np.array([lt.factors for lt in lights]), axis=0) / w.sum(axis=0)
    return dataclasses.replace(lights[0], factors=f, factors_sd=1.0 / np.sqrt(w.sum(axis=0)))


def _response_entries(base, lights) -> dict:
    """{'response', 'patch'} of the lights' factors (one per chart where there are several);
    {} unless every light has them."""
    if not lights or any(lt.factors is None for lt in lights):
        return {}
    f = np.array([lt.factors for lt in lights])
    patch = max(lt.patch_sd() for lt in lights)
    return {"response": (f[0] if len(lights) == 1 else f).tolist(),  # plain numbers: recorded
            "patch": min(patch, float(parse_sd("patch", base.get("patch", patch))))}


def check_daylight(light: Light, argument: str = "--reference") -> Light:
    """``light`` if it is a daylight the model can move along, else a clear refusal.

    A reference shot under a light off the daylight series (tungsten, illuminant A: ~2400 K
    where daylight runs from ~4000 K) leaves the fit's 'daylight' shift at the series' end with
    no curvature: its sd is not finite. Underwater such a light is indistinguishable from CDOM
    along the path (HONESTY.md's ``wrong_illuminant``): the reference shot is what can tell.

    Raises
    ------
    forward.errors.InputError
        Naming ``argument`` when the light's sd is not finite.
    """
    if not np.isfinite(light.sd):
        raise InputError(argument, f"the light in the reference shot is not daylight (its colour "
                         f"lies beyond the daylight series, CCT ~{light.cct:.0f} K; chi2/dof "
                         f"{light.chi2_dof:.2g}): give the light with --illuminant")
    return light


def measure_light(rgb, sigma, setup: ChartSetup | None = None, *, uncertain=None) -> Light:
    """The daylight's colour from a chart photographed in air (a reference shot).

    Weighted least squares (:func:`scipy.optimize.least_squares`) of the chart model at
    depth = distance = 0 (:meth:`sca.ChartModel.predict`): 'daylight' and the gain free, the
    camera's 'balance' and 'camera_shift' under their priors and the per-patch term 'patch' in
    the noise, from ``uncertain`` (default :data:`sca.budget.DEFAULT_UNCERTAIN`). Its sd is the
    package's covariance (:func:`sca.model.covariance`) at the optimum.

    Parameters
    ----------
    rgb, sigma : array_like, (3, 24)
        Patch values and their standard errors, any units (raw DN); a value with a non-finite
        or non-positive sigma (clipped, not sampled) is left out.
    setup : forward.ChartSetup, optional
        Camera, illuminant and chart as the underwater photos are fitted with (default
        :func:`forward.chart_setup`'s); the shift refers to its ``daylight_cct``.
    uncertain : dict, optional
        The camera's priors and per-patch term (the default budget's by default).

    Returns
    -------
    Light

    Raises
    ------
    forward.errors.InputError
        Naming 'rgb' or 'sigma' for values of the wrong shape or too few usable patches.
    """
    from scipy.optimize import least_squares

    from forward.imaging import chart_setup

    from .budget import parse_sd
    from .model import ChartModel, covariance

    setup = chart_setup() if setup is None else setup
    mdl = ChartModel(setup)
    M = np.asarray(rgb, float)
    sig = np.asarray(sigma, float)
    if M.shape != (mdl.m, mdl.n) or sig.shape != M.shape:
        raise InputError("rgb", f"expected patch values and sigma of shape {(mdl.m, mdl.n)}, "
                         f"got {M.shape} and {sig.shape}")
    use = (np.isfinite(M) & np.isfinite(sig) & (sig > 0)).reshape(-1)
    if use.sum() < 2 * (2 + mdl.m):
        raise InputError("sigma", f"only {int(use.sum())} usable patch values in the reference "
                         "shot")
    budget = DEFAULT_UNCERTAIN if uncertain is None else uncertain
    sd = {k: float(parse_sd(k, budget.get(k, 0.0))) for k in CAMERA_PRIORS + ("patch",)}
    Mv = M.reshape(-1)[use]
    scale = float(np.max(Mv))
    Mv = Mv / scale
    w = 1.0 / np.sqrt((sig.reshape(-1)[use] / scale) ** 2 + (sd["patch"] * Mv) ** 2)
    cams = [k for k in CAMERA_PRIORS if sd[k] > 0]
    names = ("daylight", "gain") + tuple(cams)
    m = mdl.m
    pw = np.concatenate([[0.0, 0.0]] + [np.full(m, 1.0 / sd[k] ** 2) for k in cams])

    def params(x):
        p = {"chl": 0.0, "depth": 0.0, "distance": 0.0, "daylight": x[0], "gain": x[1]}
        p.update({k: x[2 + i * m:2 + (i + 1) * m] for i, k in enumerate(cams)})
        return p

    def resid(x):
        pred = mdl.predict(params(x), jacobian=False).values[use]
        return np.concatenate([w * (Mv - pred), np.sqrt(pw[2:]) * x[2:]])

    def jac(x):
        J = mdl.predict(params(x), names).jacobian[use]
        return np.vstack([-w[:, None] * J, np.diag(np.sqrt(pw))[2:]])

    x0 = np.zeros(2 + m * len(cams))
    x0[1] = 1.0
    G1 = mdl.predict(params(x0), jacobian=False).values[use]
    x0[1] = float(np.sum(w ** 2 * Mv * G1) / np.sum(w ** 2 * G1 ** 2))  # the gain at no shift
    fit = least_squares(resid, x0, jac=jac, method="lm", x_scale="jac")
    J = mdl.predict(params(fit.x), names).jacobian[use] * w[:, None]
    cov = covariance(J, prior_weight=pw)
    dof = max(1, int(use.sum()) - 2)
    chi2 = float(np.sum((w * (Mv - mdl.predict(params(fit.x), jacobian=False).values[use])) ** 2))
    light = Light(float(fit.x[0]), float(np.sqrt(cov[0, 0])), float(setup.daylight_cct),
                  chi2 / dof)
    if not (use.all() and np.all(M > 0)):  # a value clipped or left out: the light only
        return light
    f, f_sd = patch_response(M, sig, light, mdl)
    return dataclasses.replace(light, factors=f, factors_sd=f_sd)


def patch_response(rgb, sigma, light: Light, model) -> tuple:
    """The chart's response measured in air: each value over the model's at the measured
    light, f = M / (gain G_air) (decision 0079-reference-patch-response).

    G_air is the one model function (:meth:`sca.ChartModel.predict`) at depth = distance = 0,
    the daylight at ``light.centre`` and the camera as assumed (no balance error nor curve
    shift); the gain is the weighted least-squares one (weights 1 / sigma^2). f carries what
    the in-air shot sees of the chart's reflectance error, the camera curves' error at that
    light and the light's spectrum beyond its colour, all of which multiply the direct signal
    underwater too.

    Parameters
    ----------
    rgb, sigma : array_like, (m, n)
        The shot's patch values and their standard errors (positive, finite).
    light : Light
        The light fitted to them (:func:`measure_light`).
    model : sca.ChartModel
        The chart model of the underwater fits' setup.

    Returns
    -------
    factors, factors_sd : ndarray, (m, n)
        f and its relative sd sigma / M (the shot's photon noise; the gain's is negligible).
    """
    M = np.asarray(rgb, float).reshape(-1)
    sig = np.asarray(sigma, float).reshape(-1)
    G = model.predict({"chl": 0.0, "depth": 0.0, "distance": 0.0, "daylight": light.centre},
                      jacobian=False).values
    w2 = 1.0 / sig ** 2
    gain = float(np.sum(w2 * M * G) / np.sum(w2 * G * G))
    shape = (model.m, model.n)
    return (M / (gain * G)).reshape(shape), (sig / np.abs(M)).reshape(shape)
