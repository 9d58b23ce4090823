"""Is what the user told the fit consistent with what the photos alone say?

An auxiliary reading (a water sample's a_CDOM(440), a Secchi depth, a radiometer's K_d, the
Case-1 relations) and every prior of the uncertainty budget enter the fit as Gaussian terms
(:meth:`sca.problem.Problem.evaluate`). A wrong reading is otherwise absorbed: the fit pulls the
budget's nuisances far from their priors (the CDOM slope, the daylight, the exposure gain) until
the photos agree with it, and every interval then excludes the truth with a good chi^2. Two
tests, on any :class:`sca.problem.Problem` (one chart, a batch, a dive), say so instead:

* **a reading's conflict** (:func:`reading_tests`): the likelihood-ratio statistic
  Delta chi^2 = f(with the reading) - f(without it), both minimised; where the reading agrees
  with the photos (and the budget's priors) it is chi^2 with one degree of freedom (Wilks), so
  a p-value below :data:`CONFLICT_P` flags ``reading-conflict``. For a linear model this is the
  reading's deleted residual squared, (y - h_photos)^2 / (sd^2 + var h_photos): the reading
  compared with what the photos alone predict for it, each with its own uncertainty;
* **a nuisance pulled** (:func:`nuisance_pulls`): each prior's pull (theta - mu) / sd at the
  fit; its variance is at most 1 where the prior is right (the data only shrink it), so a pull
  beyond :data:`PULL_MAX` standard deviations flags ``nuisance-pulled``.

Both flags block ``reliable`` (:data:`sca.assess.BLOCKING`), and the result names each reading
with its statistic and each pulled nuisance with its pull (``Estimate.consistency``). Decision
0062-readings-tested-against-the-photos records the thresholds.

References
----------
S. S. Wilks, "The large-sample distribution of the likelihood ratio for testing composite
hypotheses", Ann. Math. Statist. 9 (1938) 60-62. R. D. Cook & S. Weisberg, Residuals and
Influence in Regression, Chapman & Hall (1982), ch. 2 (deleted residuals).
"""

from __future__ import annotations

import numpy as np
from scipy import special

from .assess import CONFLICT_P
from .lm import LM_TOL, levenberg_marquardt

__all__ = ["PULL_MAX", "CONSISTENCY_MAX_ITER", "consistency_flag_table",
           "add_flags", "combined", "consistency_records", "finalize_batch", "finalize_single", "nuisance_pulls", "objectives_alone",
           "reading_tests", "tested", "without_observation"]

#: A nuisance whose fitted value lies more than this many of its prior's standard deviations
#: from the prior's centre is ``nuisance-pulled`` (a right prior's pull has an sd of at most 1:
#: about 5e-4 false alarms per nuisance).
PULL_MAX = 3.5
#: Levenberg-Marquardt iterations of each fit without a reading.
CONSISTENCY_MAX_ITER = 200


def without_observation(prob, j: int):
    """``prob`` without its ``j``-th auxiliary observation (the data and priors shared).

    Parameters
    ----------
    prob : sca.problem.Problem
        Any layout.
    j : int
        Index into ``prob.observations``.

    Returns
    -------
    sca.problem.Problem
        A shallow copy of the same type.
    """
    new = object.__new__(type(prob))
    new.__dict__.update(prob.__dict__)
    new.observations = [o for i, o in enumerate(prob.observations) if i != j]
    return new


def objectives_alone(prob, theta, starts=()) -> dict:
    """The optimum of ``prob`` without each of its auxiliary readings in turn.

    Parameters
    ----------
    prob : sca.problem.Problem
        The fitted problem, its readings in ``prob.observations``.
    theta : ndarray, (N, p)
        The optimum with every reading (LM coordinates): the first start.
    starts : sequence of ndarray, (N, p), optional
        Further start points (e.g. the fit of the photos alone); the best of all is taken.

    Returns
    -------
    dict
        Reading name -> (N,) objective without it (NaN for units without that reading).
    """
    theta = np.asarray(theta, float)
    N = theta.shape[0]
    out = {}
    for j, obs in enumerate(prob.observations):
        have = np.isfinite(np.broadcast_to(np.asarray(obs.value, float), (N,)))
        best = np.full(N, np.nan)
        if have.any():
            rows = np.flatnonzero(have)
            alone = without_observation(prob, j)
            f = np.full(rows.size, np.inf)
            for start in (theta,) + tuple(starts):
                _, fw, _, _ = levenberg_marquardt(alone, np.asarray(start, float)[rows],
                                                  max_iter=CONSISTENCY_MAX_ITER, tol=LM_TOL,
                                                  f_exact=np.zeros(rows.size), rows=rows)
                f = np.fmin(f, fw)
            best[rows] = f
        out[obs.name] = best
    return out


def reading_tests(objective, alone) -> dict:
    """The likelihood-ratio test of every reading: Delta chi^2 = min over the candidates (the
    path models) of the objective with every reading, minus the min without that reading.

    Parameters
    ----------
    objective : array_like, (N, K)
        The objective with every reading of each of K candidate models (K = 1: one model).
    alone : dict
        Reading name -> (N, K) objective without it (:func:`objectives_alone` of each model).

    Returns
    -------
    dict
        Reading name -> (statistic (N,), p-value (N,)): Delta chi^2 >= 0 and
        P(chi^2_1 > Delta chi^2); NaN for units without that reading.
    """
    f = np.asarray(objective, float)
    f = np.where(np.isfinite(f), f, np.inf).min(axis=1)
    out = {}
    for name, fa in alone.items():
        fa = np.asarray(fa, float).reshape(f.shape[0], -1)
        have = np.all(np.isfinite(fa), axis=1)
        low = np.where(have, fa.min(axis=1), 0.0)
        stat = np.where(have, np.maximum(f - low, 0.0), np.nan)
        out[name] = (stat, np.where(have, special.chdtrc(1, np.where(have, stat, 0.0)), np.nan))
    return out


def nuisance_pulls(prob, theta) -> dict:
    """Each prior's pull (theta - mu) / sd at ``theta``.

    A name of k > 1 columns (a per-channel or per-photo nuisance, the chart's per-patch terms)
    reports its largest pull, adjusted for having k chances (Sidak: the pull of one column
    whose two-sided tail probability is 1 - (1 - P)^k, P that of the largest), so that
    :data:`PULL_MAX` means one false alarm rate for every name.

    Parameters
    ----------
    prob : sca.problem.Problem
        A problem with the budget's priors (``prior_mean``, ``prior_weight``) or none.
    theta : ndarray, (N, p)
        The optimum (LM coordinates: the priors' own).

    Returns
    -------
    dict
        Name -> (N,) signed pull, in its prior's standard deviations; only names with a prior.
    """
    if prob.prior_mean is None:
        return {}
    theta = np.asarray(theta, float)
    w = np.asarray(prob.prior_weight, float)
    pull = np.where(w > 0, (theta - prob.prior_mean) * np.sqrt(np.where(w > 0, w, 0.0)), 0.0)
    out = {}
    for name in prob.free:
        cols = [j for j in prob.columns(name) if np.any(w[:, j] > 0)]
        if not cols:
            continue
        p = pull[:, cols]
        top = p[np.arange(p.shape[0]), np.argmax(np.abs(p), axis=1)]
        if len(cols) > 1:  # Sidak: P_k = 1 - (1 - P_1)^k, as one column's pull
            p1 = np.minimum(special.erfc(np.abs(top) / np.sqrt(2.0)), 1.0)
            with np.errstate(divide="ignore"):  # P_1 = 1 (a pull of 0): P_k = 1
                tail = -np.expm1(len(cols) * np.log1p(-p1))
            top = np.sign(top) * np.sqrt(2.0) * special.erfcinv(np.maximum(tail, 1e-300))
        out[name] = top
    return out


def consistency_flag_table(tests: dict, pulls: dict, n: int, uncertain=None) -> dict:
    """{'reading-conflict': (N,) bool, 'nuisance-pulled': (N,) bool, 'reference-conflict':
    (N,) bool} of :func:`reading_tests` and :func:`nuisance_pulls` (:data:`CONFLICT_P`,
    :data:`PULL_MAX`) and of the budget's reference shots (:func:`sca.reference.conflict_of`:
    two shots bracketing the dive that disagree).

    Parameters
    ----------
    tests, pulls : dict
        As :func:`reading_tests` and :func:`nuisance_pulls` return.
    n : int
        N, the number of units.
    uncertain : dict, optional
        The budget the units were fitted with.

    Returns
    -------
    dict
    """
    conflict, pulled = np.zeros(n, bool), np.zeros(n, bool)
    for _, p in tests.values():
        conflict |= np.asarray(p, float) < CONFLICT_P
    for v in pulls.values():
        pulled |= np.abs(np.asarray(v, float)) > PULL_MAX
    from .reference import CONFLICT_FLAG, conflict_of

    return {"reading-conflict": conflict, "nuisance-pulled": pulled,
            CONFLICT_FLAG: np.full(n, conflict_of(uncertain))}


def consistency_records(tests: dict, pulls: dict, i: int = 0) -> dict:
    """Unit ``i``'s tests as plain numbers: {'readings': {name: {'delta_chi2', 'p',
    'conflict'}}, 'pulls': {name: pull}, 'pull_max': PULL_MAX, 'conflict_p': CONFLICT_P}
    (readings the unit does not have are left out).

    Parameters
    ----------
    tests, pulls : dict
        As :func:`reading_tests` and :func:`nuisance_pulls` return.
    i : int, optional
        The unit (default 0).

    Returns
    -------
    dict
    """
    readings = {name: {"delta_chi2": float(s[i]), "p": float(p[i]),
                       "conflict": bool(p[i] < CONFLICT_P)}
                for name, (s, p) in tests.items() if np.isfinite(s[i])}
    return {"readings": readings, "pulls": {k: float(v[i]) for k, v in pulls.items()},
            "pull_max": PULL_MAX, "conflict_p": CONFLICT_P}


def combined(objectives, alones, pulls_of_best, uncertain=None) -> tuple:
    """The tests of N units fitted under K candidate models, and the flags they raise.

    Parameters
    ----------
    objectives : sequence of K arrays, (N,)
        Each candidate's objective with every reading.
    alones : sequence of K dicts
        Each candidate's :func:`objectives_alone` (name -> (N,)).
    pulls_of_best : dict
        :func:`nuisance_pulls` of the chosen candidate of each unit (name -> (N,)).
    uncertain : dict, optional
        The budget (:func:`consistency_flag_table`).

    Returns
    -------
    tests : dict
        As :func:`reading_tests`.
    table : dict
        As :func:`consistency_flag_table`.
    """
    obj = np.column_stack([np.asarray(o, float).reshape(-1) for o in objectives])
    names = dict.fromkeys(k for a in alones for k in a)
    alone = {k: np.column_stack([np.asarray(a.get(k, np.full(obj.shape[0], np.nan)), float)
                                 .reshape(-1) for a in alones]) for k in names}
    tests = reading_tests(obj, alone)
    return tests, consistency_flag_table(tests, pulls_of_best, obj.shape[0], uncertain)


def add_flags(flags, table, i: int | None = None) -> tuple:
    """``flags`` (a tuple of one unit) with the raised flags of ``table`` (unit ``i``; a
    one-unit table where None) appended."""
    i = 0 if i is None else i
    return tuple(dict.fromkeys(tuple(flags) + tuple(k for k, v in table.items() if v[i])))


def finalize_single(ests, best: int):
    """The consistency of one chart fitted under the candidates ``ests`` (sca.Estimate each,
    ``consistency`` holding its 'alone' objectives and 'pulls'), ``best`` the chosen one.

    Returns
    -------
    record : dict
        :func:`consistency_records` of the chart.
    table : dict
        As :func:`consistency_flag_table`, one unit.
    """
    pulls = {k: np.array([v]) for k, v in ests[best].consistency.get("pulls", {}).items()}
    tests, table = combined([[e.objective] for e in ests],
                            [{k: [v] for k, v in e.consistency.get("alone", {}).items()}
                             for e in ests], pulls, ests[best].uncertain)
    return consistency_records(tests, pulls), table


def finalize_batch(ests, best):
    """The consistency of N charts fitted under the candidates ``ests`` (sca.BatchEstimate
    each, ``consistency`` holding its 'alone' objectives and 'pulls'), ``best`` (N,) the index
    of each chart's chosen candidate.

    Returns
    -------
    record : dict
        {'readings': {name: {'delta_chi2': (N,), 'p': (N,), 'conflict': (N,) bool}},
        'pulls': {name: (N,)}, 'pull_max', 'conflict_p'}.
    table : dict
        As :func:`consistency_flag_table`.
    """
    best = np.asarray(best, int)
    rows = np.arange(best.size)
    names = dict.fromkeys(k for e in ests for k in e.consistency.get("pulls", {}))
    pulls = {k: np.stack([np.asarray(e.consistency["pulls"].get(k, np.zeros(best.size)), float)
                          for e in ests])[best, rows] for k in names}
    tests, table = combined([e.objective for e in ests],
                            [e.consistency.get("alone", {}) for e in ests], pulls,
                            ests[0].uncertain if ests else None)
    readings = {k: {"delta_chi2": s, "p": p, "conflict": p < CONFLICT_P}
                for k, (s, p) in tests.items()}
    return {"readings": readings, "pulls": pulls, "pull_max": PULL_MAX,
            "conflict_p": CONFLICT_P}, table


def tested(e):
    """``e`` (a :class:`sca.Estimate` of one path model, its ``consistency`` holding 'alone'
    and 'pulls') with its readings and priors tested against the photos
    (:func:`finalize_single`): ``consistency`` as documented, the flags ``reading-conflict`` /
    ``nuisance-pulled`` where raised, ``reliable`` accordingly. Several path models are tested
    together by :func:`sca.pathmodels.combine_single` instead.

    Parameters
    ----------
    e : sca.Estimate

    Returns
    -------
    sca.Estimate
    """
    import dataclasses

    from .assess import is_reliable

    consistency, table = finalize_single([e], 0)
    flags = add_flags(e.flags, table)
    return dataclasses.replace(e, consistency=consistency, flags=flags,
                               reliable=is_reliable(flags))
