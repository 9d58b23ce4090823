"""Relation priors of Case-1-like water: the other absorbers tied to chlorophyll, a user's choice.

In Case-1 water (Morel & Prieur 1977) the dissolved and detrital matter co-vary with the
phytoplankton, so a_CDOM(440) and the non-algal particles' a_NAP(440) follow C on average,

    ln(a_q(440) + floor) = ln alpha_q + beta_q ln(C + chl_floor) + e_q,   e_q ~ N(0, sd_q^2),

each relation with its own log-normal scatter sd_q, for q = CDOM, NAP and phytoplankton
(:data:`CASE1_QUANTITIES`). :func:`case1_observations` turns the relations into
:class:`sca.problem.Observation` s of the derived quantity

    h_q(params) = ln(a_q(440; params) + floor) - ln alpha_q - beta_q ln(C + chl_floor),

observed as 0 +- sd_q, so they enter the objective of every estimator as the priors and the
auxiliary measurements do (:mod:`sca.auxiliary`: ``auxiliary={'case1': True}``). a_q(440) is
the model's own: a_CDOM(440) is the parameter 'cdom'; a_NAP(440) and a_phi(440) are eqs 8 and 10
evaluated by :meth:`forward.WaterTerms.path_coefficient` (the non-water absorption at 440 nm
with a_CDOM = 0 and the other absorber's scale 0, so one term alone, with its derivatives by C
and by its equation's constants when they are free): no term is restated here.

**The particle relations act through their scales.** The model ties a_NAP and a_phi to C
exactly (eqs 8 and 10), so their relations have something to say only where the fit frees
``nap_scale`` / ``phyto_scale`` (``uncertain``); then the relation is the scale's prior,
log-normal about NOMAD's own law. Where a scale is held at the water's constant, its relation
is inert (h = 0: it would otherwise act on C alone, an artefact of two laws for one
quantity). :data:`CASE1_UNCERTAIN` frees both with priors ten times the paper's values (no
prior of their own): the choice is ``auxiliary={'case1': True}`` with
``uncertain={..., **CASE1_UNCERTAIN}``. The CDOM relation always acts.

The constants are a table of ``data/`` (:data:`CASE1_TABLE`), learned on the EVEN rows of NASA
NOMAD v2 (Werdell & Bailey 2005; ``experiments/realwater/biooptical.py``, ``make real-data``
writes the table and tests the relations on the odd rows). They describe Case-1-like water;
in CDOM-rich coastal or inland water (a river plume, a lake) the relation is wrong, and a
measured a_CDOM (``auxiliary={'cdom': ...}``) is the right input instead. Never a default.

References
----------
A. Morel and L. Prieur, "Analysis of variations in ocean color", Limnol. Oceanogr. 22 (1977)
709-722. A. Bricaud, A. Morel, M. Babin, K. Allali and H. Claustre, "Variations of light
absorption by suspended particles with chlorophyll a concentration in oceanic (case 1)
waters", J. Geophys. Res. 103 (1998) 31033-31044. A. Morel, "Are the empirical relationships
describing the bio-optical properties of case 1 waters consistent and internally
compatible?", J. Geophys. Res. 114 (2009) C01016. P. J. Werdell and S. W. Bailey, Remote
Sens. Environ. 98 (2005) 122-140 (NOMAD).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forward.spectra import read_table
from forward.water import COEFFICIENT_PARAMS, NONWATER_ABSORPTION_TERMS

from .problem import Observation
from forward.errors import InputError

__all__ = ["CASE1_QUANTITIES", "CASE1_TABLE", "CASE1_UNCERTAIN", "REFERENCE_NM", "Relation",
           "binds", "case1_observations", "fit_relation", "read_case1", "relation_observation"]

#: File of ``data/`` with the relations' constants (learned on NOMAD's even rows).
CASE1_TABLE = "case1_relations_nomad_even.csv"
#: The quantities a relation ties to C: a_CDOM(440) and a_NAP(440), m^-1.
CASE1_QUANTITIES = ("cdom", "nap", "phyto")
#: The reference wavelength of the relations, nm (the model's a_CDOM and a_NAP are given there).
REFERENCE_NM = 440.0
#: The scale through which each particle relation acts (its relation is inert where the scale
#: is not a free parameter of the fit).
SCALES = {"nap": "nap_scale", "phyto": "phyto_scale"}
#: eq 8's and eq 10's scales freed for the relations (``uncertain``): prior sds ten times the
#: paper's values (0.0124, 0.0378 m^-1), i.e. no prior of their own: the relations are.
CASE1_UNCERTAIN = {"nap_scale": 0.124, "phyto_scale": 0.378}


@dataclass(frozen=True)
class Relation:
    """ln(a_q(440) + floor) = ln alpha + beta ln(C + chl_floor) +- sd.

    Attributes
    ----------
    quantity : str
        'cdom' (a_CDOM(440)) or 'nap' (a_NAP(440)).
    alpha : float
        a_q(440) at C = 1 mg m^-3, m^-1.
    beta : float
        The exponent of C.
    sd : float
        The scatter of ln a_q about the relation (the standard deviation of the residual).
    floor : float
        Added to a_q before the logarithm, m^-1 (keeps h finite at a_q = 0).
    chl_floor : float
        Added to C before the logarithm, mg m^-3 (keeps h finite at C = 0).
    n : int
        Stations the constants were learned on (0: not learned from data).
    """

    quantity: str
    alpha: float
    beta: float
    sd: float
    floor: float
    chl_floor: float
    n: int = 0

    def __post_init__(self):
        if self.quantity not in CASE1_QUANTITIES:
            raise InputError("quantity", f"expected one of {CASE1_QUANTITIES}, got "
                             f"{self.quantity!r}")
        for name in ("alpha", "sd", "floor", "chl_floor"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(name, f"must be finite and > 0, got {v!r}")
        if not np.isfinite(self.beta):
            raise InputError("beta", f"must be finite, got {self.beta!r}")

    def predict(self, chl):
        """The relation's median a_q(440) at C, m^-1 (floor removed).

        Parameters
        ----------
        chl : float or array_like
            C, mg m^-3.

        Returns
        -------
        ndarray
            alpha (C + chl_floor)^beta - floor, m^-1.
        """
        return self.alpha * (np.asarray(chl, float) + self.chl_floor) ** self.beta - self.floor


def read_case1(filename: str = CASE1_TABLE) -> dict:
    """The relations of a table of ``data/``.

    Parameters
    ----------
    filename : str, optional
        Default :data:`CASE1_TABLE`; columns ``quantity, alpha_per_m, beta, sd_ln,
        floor_per_m, chl_floor_mg_m3, n_stations``.

    Returns
    -------
    dict
        quantity -> :class:`Relation`.
    """
    cols, rows = read_table(filename)
    out = {}
    for row in rows:
        r = dict(zip(cols, row))
        out[r["quantity"]] = Relation(r["quantity"], float(r["alpha_per_m"]), float(r["beta"]),
                                      float(r["sd_ln"]), float(r["floor_per_m"]),
                                      float(r["chl_floor_mg_m3"]), int(r["n_stations"]))
    return out


def fit_relation(quantity: str, chl, value, *, floor: float, chl_floor: float) -> Relation:
    """Learn a relation: ordinary least squares of ln(a + floor) on ln(C + chl_floor).

    Parameters
    ----------
    quantity : str
        'cdom' or 'nap'.
    chl : array_like, (n,)
        In-situ C, mg m^-3.
    value : array_like, (n,)
        The paired a_q(440), m^-1; pairs with a NaN are left out.
    floor, chl_floor : float
        As :class:`Relation`.

    Returns
    -------
    Relation
        sd is the residual's standard deviation with n - 2 degrees of freedom.

    Raises
    ------
    ValueError
        With fewer than 3 pairs.
    """
    chl, value = np.asarray(chl, float), np.asarray(value, float)
    ok = np.isfinite(chl) & np.isfinite(value) & (chl >= 0) & (value >= 0)
    if ok.sum() < 3:
        raise InputError("value", f"{int(ok.sum())} valid pairs; at least 3 are needed")
    x = np.log(chl[ok] + chl_floor)
    y = np.log(value[ok] + floor)
    beta, ln_alpha = np.polyfit(x, y, 1)
    resid = y - ln_alpha - beta * x
    sd = float(np.sqrt(np.sum(resid ** 2) / (ok.sum() - 2)))
    return Relation(quantity, float(np.exp(ln_alpha)), float(beta), sd, floor, chl_floor,
                    int(ok.sum()))


#: Each particle absorber's own constants, and the other's scale (set to 0 to isolate it).
_PARTICLES = {"nap": (("nap_scale", "nap_exponent", "nap_slope"), "phyto_scale"),
              "phyto": (("phyto_scale", "phyto_exponent"), "nap_scale")}


def _particle_440(kind, water, params, wrt):
    """a_NAP(440) (eq 8) or a_phi(440) (eq 10) and its derivatives by ``wrt`` (C and the
    equation's constants): the non-water absorption at 440 nm with a_CDOM = 0 and the other
    absorber's scale 0."""
    own, other = _PARTICLES[kind]
    chl = np.atleast_1d(np.asarray(params["chl"], float))
    values = {k: v for k, v in params.items() if k in COEFFICIENT_PARAMS}
    values[other] = 0.0
    names = tuple(n for n in wrt if n == "chl" or n in own)
    g = water.on_grid(np.array([REFERENCE_NM - 1.0, REFERENCE_NM, REFERENCE_NM + 1.0]))
    a, d = g.path_coefficient(chl, np.zeros_like(chl), values=values, wrt=names, floor=1e-300,
                              terms=NONWATER_ABSORPTION_TERMS)
    return a[..., 1], {k: v[..., 1] for k, v in d.items()}


def _cdom_440(water, params, wrt):
    """a_CDOM(440), the parameter itself, and d/d cdom = 1."""
    cdom = np.atleast_1d(np.asarray(params.get("cdom", 0.0), float))
    return cdom, ({"cdom": np.ones_like(cdom)} if "cdom" in wrt else {})


_QUANTITY = {"cdom": _cdom_440,
             "nap": lambda water, params, wrt: _particle_440("nap", water, params, wrt),
             "phyto": lambda water, params, wrt: _particle_440("phyto", water, params, wrt)}


def relation_observation(relation: Relation, water) -> Observation:
    """The relation as an observation: h = ln(a_q + floor) - ln alpha - beta ln(C + chl_floor)
    observed as 0 +- sd (inert, h = 0, for a particle relation whose scale is not among the
    parameters it is given: see the module's notes).

    Parameters
    ----------
    relation : Relation
        The relation.
    water : forward.Water
        The water model of the fit (a_NAP(440) is its eq 8).

    Returns
    -------
    Observation
        Named ``case1_<quantity>``.
    """
    quantity = _QUANTITY[relation.quantity]
    ln_alpha, beta = np.log(relation.alpha), relation.beta
    scale = SCALES.get(relation.quantity)

    def h(params, wrt):
        chl = np.atleast_1d(np.asarray(params["chl"], float))
        if scale is not None and scale not in params:  # held at the water's constant: inert
            return np.zeros(chl.shape), {}
        a, da = quantity(water, params, wrt)
        inv = 1.0 / (a + relation.floor)
        value = np.log(a + relation.floor) - ln_alpha - beta * np.log(chl + relation.chl_floor)
        d = {k: v * inv for k, v in da.items()}
        if "chl" in wrt:
            d["chl"] = d.get("chl", 0.0) - beta / (chl + relation.chl_floor)
        return value, d
    return Observation(f"case1_{relation.quantity}", 0.0, relation.sd, h)


def case1_observations(water, choice=True, relations: dict | None = None) -> list:
    """The observations of the Case-1 relation prior.

    Parameters
    ----------
    water : forward.Water
        The water model of the fit.
    choice : bool, sequence of str or dict, optional
        True: every relation of the table; a sequence: those quantities (of
        :data:`CASE1_QUANTITIES`); a dict quantity -> :class:`Relation`: those relations (e.g.
        learned on a user's own stations by :func:`fit_relation`); False or empty: none.
    relations : dict, optional
        quantity -> :class:`Relation` (default: :func:`read_case1`).

    Returns
    -------
    list of Observation

    Raises
    ------
    ValueError
        For an unknown quantity or a choice that is neither a bool nor a sequence of names.
    """
    if choice is False or choice is None:
        return []
    if isinstance(choice, dict):
        relations, choice = choice, list(choice)
        bad = [r for r in relations.values() if not isinstance(r, Relation)]
        if bad:
            raise InputError("auxiliary['case1']", f"a dict of relations needs Relation values, "
                             f"got {bad[0]!r}")
    table = read_case1() if relations is None else dict(relations)
    if choice is True:
        names = [q for q in CASE1_QUANTITIES if q in table]
    elif isinstance(choice, str | bytes) or not hasattr(choice, "__iter__"):
        raise InputError("auxiliary['case1']", f"expected True or a sequence of {CASE1_QUANTITIES},"
                         f" got {choice!r}")
    else:
        names = list(choice)
        bad = [q for q in names if q not in table]
        if bad:
            raise InputError("auxiliary['case1']", f"no relation for {bad}; choose from "
                             f"{sorted(table)}")
    return [relation_observation(table[q], water) for q in names]


def binds(observation: Observation, names) -> bool:
    """Whether an observation acts in a fit whose free parameters are ``names``: every one but
    a particle relation whose scale is not free (:func:`relation_observation`).

    Parameters
    ----------
    observation : Observation
        Any observation (:mod:`sca.auxiliary`).
    names : iterable of str
        The fit's free parameters.

    Returns
    -------
    bool
    """
    quantity = observation.name.removeprefix("case1_") if observation.name.startswith(
        "case1_") else None
    return quantity not in SCALES or SCALES[quantity] in set(names)
