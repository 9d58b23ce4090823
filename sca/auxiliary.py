"""Auxiliary measurements: what a user measured besides the photo, fused in the same fit.

Each is an :class:`sca.problem.Observation` of a quantity the model predicts from its parameters,
with the measurement's standard deviation (and, where the quantity comes from an empirical
relation, the relation's own scatter added in quadrature). They enter the objective of every
estimator as the priors do (:meth:`sca.problem.Problem.evaluate`), so the fit, the intervals
and the covariance (and the Cramér-Rao bound of a design) include them.

* ``cdom``: a_CDOM(440) of a water sample, m^-1 (a filtered-sample spectrophotometer reading);
* ``secchi``: a Secchi-disk depth, m, through the classical relation
  z_SD = Gamma / (c + K_d) at 555 nm (the photopic peak), Gamma = :data:`SECCHI_GAMMA` with a
  relative scatter :data:`SECCHI_GAMMA_REL` (Tyler 1968; Preisendorfer 1986: the coupling
  constant varies about 8.7 with the observer, the disk and the light);
* ``kd``: a radiometer's K_d at one or more bands, m^-1, against the model's
  K_d = (a + b_b) / mu_d (Gordon 1989), with the model's own error :data:`KD_MODEL_REL`
  (as :mod:`sca.spectral`'s) added in quadrature;
* ``case1``: not a measurement but a documented relation prior for Case-1-like water, a choice
  the user makes (``True``, or a sequence of 'cdom', 'nap', 'phyto'): a_CDOM(440), a_NAP(440)
  and a_phi(440) tied to C with the log-normal scatter measured on NASA NOMAD's even rows
  (:mod:`sca.biooptical`; the particle relations act where the fit frees their scales).

A measured chart (its reflectance spectra from a spectrometer) is not an observation: it replaces
the nominal chart in the setup and the budget's per-patch term (``measure`` and the CLI's
``--chart-reflectance``).

References
----------
J. E. Tyler, "The Secchi disc", Limnol. Oceanogr. 13 (1968) 1-6. R. W. Preisendorfer,
"Secchi disk science: visual optics of natural waters", Limnol. Oceanogr. 31 (1986) 909-926.
H. R. Gordon, "Can the Lambert-Beer law be applied to the diffuse attenuation coefficient of
ocean water?", Limnol. Oceanogr. 34 (1989) 1389-1409.
"""

from __future__ import annotations

import numpy as np

from forward.water import BEAM_TERMS, COEFFICIENT_PARAMS, DIFFUSE_TERMS

from .biooptical import case1_observations
from .problem import Observation
from forward.errors import InputError

__all__ = ["AUXILIARY", "KD_MODEL_REL", "SECCHI_GAMMA", "SECCHI_GAMMA_REL", "SECCHI_NM",
           "auxiliary_observations", "cdom_observation", "kd_observation", "planned",
           "secchi_observation"]

#: The names :func:`auxiliary_observations` takes.
AUXILIARY = ("cdom", "secchi", "kd", "case1")
#: Tyler's coupling constant of the Secchi depth: z_SD (c + K_d) = Gamma (Tyler 1968).
SECCHI_GAMMA = 8.7
#: Its relative scatter (observer, disk, sky, waves: Preisendorfer 1986 gives a range of about
#: 6-10), added in quadrature to the depth reading's own sd.
SECCHI_GAMMA_REL = 0.2
#: The wavelength of the Secchi relation's c and K_d, nm (the eye's photopic peak).
SECCHI_NM = 555.0
#: Relative error of K_d ~ (a + b_b) / mu_d itself (as :data:`sca.spectral.KD_MODEL_ERROR`).
KD_MODEL_REL = 0.15


def _spectral(params, wrt):
    chl = np.atleast_1d(np.asarray(params["chl"], float))
    cdom = np.atleast_1d(np.asarray(params.get("cdom", 0.0), float))
    consts = {k: v for k, v in params.items() if k in COEFFICIENT_PARAMS}
    names = tuple(n for n in wrt if n in ("chl", "cdom") + COEFFICIENT_PARAMS)
    return chl, cdom, consts, names


def _coefficient(water, band, terms, params, wrt):
    chl, cdom, consts, names = _spectral(params, wrt)
    g = water.on_grid(np.array([band - 1.0, band, band + 1.0]))
    c, d = g.path_coefficient(chl, cdom, values=consts, wrt=names, floor=1e-300, terms=terms)
    return c[..., 1], {k: v[..., 1] for k, v in d.items()}


def cdom_observation(value, sd) -> Observation:
    """a_CDOM(440) of a water sample.

    Parameters
    ----------
    value, sd : float or array_like, (N,)
        m^-1 (NaN: not measured for that unit).

    Returns
    -------
    Observation
    """
    def h(params, wrt):
        return np.atleast_1d(np.asarray(params.get("cdom", 0.0), float)), (
            {"cdom": np.ones(np.size(params.get("cdom", 0.0)))} if "cdom" in wrt else {})
    return Observation("cdom", value, sd, h)


def secchi_observation(value, sd, water) -> Observation:
    """A Secchi-disk depth through z_SD = Gamma / (c + K_d) at :data:`SECCHI_NM`.

    Parameters
    ----------
    value, sd : float or array_like, (N,)
        The depth where the disk disappears, m, and the reading's sd (the relation's scatter,
        :data:`SECCHI_GAMMA_REL`, is added in quadrature).
    water : forward.Water
        The water model of the fit.

    Returns
    -------
    Observation
    """
    value = np.asarray(value, float)
    total = np.hypot(np.asarray(sd, float), SECCHI_GAMMA_REL * value)

    def h(params, wrt):
        c, dc = _coefficient(water, SECCHI_NM, BEAM_TERMS, params, wrt)
        k, dk = _coefficient(water, SECCHI_NM, DIFFUSE_TERMS, params, wrt)
        z = SECCHI_GAMMA / (c + k)
        fac = -z / (c + k)
        return z, {n: fac * (dc.get(n, 0.0) + dk.get(n, 0.0)) for n in set(dc) | set(dk)}
    return Observation("secchi", value, total, h)


def kd_observation(wavelength, value, sd, water) -> Observation:
    """A radiometer's K_d at one band.

    Parameters
    ----------
    wavelength : float
        nm.
    value, sd : float or array_like, (N,)
        m^-1 (the model's own error, :data:`KD_MODEL_REL`, added in quadrature).
    water : forward.Water
        The water model of the fit.

    Returns
    -------
    Observation
    """
    value = np.asarray(value, float)
    total = np.hypot(np.asarray(sd, float), KD_MODEL_REL * value)

    def h(params, wrt):
        return _coefficient(water, float(wavelength), DIFFUSE_TERMS, params, wrt)
    return Observation(f"kd_{float(wavelength):g}", value, total, h)


def planned(auxiliary, water, params) -> dict:
    """``auxiliary`` with every measurement's value replaced by the model's at ``params``: a
    design's measurements (a Cramér-Rao bound needs their sds, not their values; a value may
    be None).

    Parameters
    ----------
    auxiliary : dict or None
        As :func:`auxiliary_observations`.
    water : forward.Water
        The water model.
    params : dict
        The model's parameters of the conditions ('chl', 'cdom', coefficients), (N,) each.

    Returns
    -------
    dict
    """
    if not auxiliary:
        return {}
    dummy = {k: ({b: (1.0, e[1]) for b, e in v.items()} if k == "kd" else (1.0, v[1]))
             for k, v in auxiliary.items() if k != "case1"}
    out = {k: v for k, v in auxiliary.items() if k == "case1"}  # a relation: no value to plan
    for obs in auxiliary_observations(dummy, water):
        value, _ = obs.function(params, ())
        if obs.name.startswith("kd_"):
            band = float(obs.name[3:])
            (entry,) = [e for b, e in auxiliary["kd"].items() if float(b) == band]
            out.setdefault("kd", {})[band] = (value, entry[1])
        else:
            out[obs.name] = (value, auxiliary[obs.name][1])
    return out


def auxiliary_observations(auxiliary, water) -> list:
    """The observations of a user's ``auxiliary=`` dict.

    Parameters
    ----------
    auxiliary : dict or None
        'cdom': (value, sd) m^-1; 'secchi': (depth, sd) m; 'kd': {wavelength nm: (value, sd)}
        m^-1. Values and sds may be (N,) arrays (one per chart; NaN: not measured). 'case1':
        True (or a sequence of 'cdom', 'nap', 'phyto', or a dict of one's own relations), the
        Case-1 relation prior
        (:func:`sca.biooptical.case1_observations`).
    water : forward.Water
        The water model of the fit.

    Returns
    -------
    list of Observation

    Raises
    ------
    ValueError
        Naming ``auxiliary`` for an unknown name, a malformed entry, or a value or sd that is
        not finite and positive (NaN values excepted).
    """
    if not auxiliary:
        return []
    if not isinstance(auxiliary, dict):
        raise InputError("auxiliary", "expected a dict like {'cdom': (0.1, 0.02)}")
    bad = set(auxiliary) - set(AUXILIARY)
    if bad:
        raise InputError("auxiliary", f"unknown measurement(s) {sorted(bad)}; choose from "
                         f"{AUXILIARY}")

    def pair(label, entry):
        try:
            v, s = (np.asarray(x, float) for x in entry)
        except (TypeError, ValueError):
            raise InputError(f"auxiliary[{label!r}]", f"expected (value, sd), got {entry!r}") \
                from None
        given = np.isfinite(v)
        if np.any(v[given] <= 0) or np.any(~(np.broadcast_to(s, v.shape)[given] > 0)) \
                or np.any(~np.isfinite(np.broadcast_to(s, v.shape)[given])):
            raise InputError(f"auxiliary[{label!r}]", f"the value and its sd must be finite and "
                             f"> 0, got {entry!r}")
        return v, s
    out = []
    if "cdom" in auxiliary:
        out.append(cdom_observation(*pair("cdom", auxiliary["cdom"])))
    if "case1" in auxiliary:
        out += case1_observations(water, auxiliary["case1"])
    if "secchi" in auxiliary:
        out.append(secchi_observation(*pair("secchi", auxiliary["secchi"]), water))
    if "kd" in auxiliary:
        kd = auxiliary["kd"]
        if not isinstance(kd, dict) or not kd:
            raise InputError("auxiliary['kd']", "expected {wavelength nm: (value, sd)}")
        for wl, entry in kd.items():
            try:
                band = float(wl)
            except (TypeError, ValueError):
                raise InputError("auxiliary['kd']", f"a wavelength is not a number: {wl!r}") \
                    from None
            if not 400.0 <= band <= 700.0:
                raise InputError("auxiliary['kd']", f"{band:g} nm lies outside 400-700 nm")
            out.append(kd_observation(band, *pair(f"kd {band:g} nm", entry), water))
    return out
