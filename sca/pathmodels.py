"""The path model decided by the data where they can: a likelihood-ratio choice among the
candidates of :data:`forward.water.PATH_MODELS`, or intervals that span them.

Candidates: the paper's attenuation along depth + distance ('beam', eqs 3-4), absorption only
('absorption', eq 13 as printed) and the physical split ('split': the diffuse attenuation
K_d = (a + b_b) / mu_d on the way down, the beam attenuation c along the camera's ray). Each
chart is fitted under each candidate (the same estimator, the same budget); the candidates
whose objective is within :data:`PATH_MODEL_DELTA` of the best one are *supported*. One
supported model is the data's choice; where several are, the 95 % intervals of C and a_CDOM
span all of them (their union) and the flag ``path-model-span`` says that the answer depends on
a modelling choice the data cannot make. The point estimate is the best-fitting model's.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from forward.water import PATH_MODELS

from .assess import BLOCKING
from .consistency import add_flags, finalize_single
from .derived import verdict, verdicts_of
from forward.errors import InputError

__all__ = ["PATH_MODEL_DELTA", "SPAN_FLAG", "candidates", "supported", "combine_batch",
           "combine_single", "span_note"]

#: Candidates whose objective (chi^2 with the budget's priors) is within this of the best
#: are supported by the data: chi^2_1(0.95), the rise that bounds the profile intervals.
PATH_MODEL_DELTA = 3.841458820694124
#: The flag of an interval that spans several supported path models (information only).
SPAN_FLAG = "path-model-span"


def span_note(flags, path_models) -> str:
    """What the flag :data:`SPAN_FLAG` means, in words, where ``flags`` hold it ('' where
    not): the sentence ``uw3p measure`` prints and measurement.json's notes hold (decision
    0078-path-model-span-explained).

    Parameters
    ----------
    flags : iterable of str
    path_models : iterable of str or dict
        The supported path models (an estimate's ``path_models``), or every candidate's
        objective (a joint estimate's ``path_models``: name -> chi^2), of which the supported.

    Returns
    -------
    str
    """
    if SPAN_FLAG not in tuple(flags):
        return ""
    if isinstance(path_models, dict):
        ok = supported(np.array([list(path_models.values())], float))[1][0]
        path_models = [m for m, k in zip(path_models, ok) if k]
    return (f"{SPAN_FLAG}: the path models {' and '.join(path_models)} fit the chart equally "
            "well, so every 95 % interval spans them (their union); information, not a fault: "
            "what the photos measure, the path's attenuation c and optical depth tau, is the "
            "same under each")


#: The interval flags a supported model passes on to the combined result.
_INTERVAL_FLAGS = ("unbounded-chl", "unbounded-cdom", "interval-failed")


def candidates(path_models, water, budget_applies: bool) -> tuple:
    """The path models to fit: ``path_models`` as given, else every candidate where an
    uncertainty budget applies and only the water's own where the model is exact.

    Parameters
    ----------
    path_models : sequence of str or None
        Names of :data:`forward.water.PATH_MODELS`.
    water : forward.Water
        The water model (its ``path_model`` comes first).
    budget_applies : bool
        An uncertainty budget is applied to the fit (noise known, ``uncertain`` not ``{}``).

    Returns
    -------
    tuple of str
        The water's own model first.

    Raises
    ------
    ValueError
        For an unknown name.
    """
    if path_models is None:
        names = PATH_MODELS if budget_applies else (water.path_model,)
    else:
        names = (path_models,) if isinstance(path_models, str) else tuple(path_models)
        bad = [n for n in names if n not in PATH_MODELS]
        if bad or not names:
            raise InputError("path_models", f"expected names among {PATH_MODELS}, got {path_models!r}")
    return (water.path_model,) + tuple(n for n in dict.fromkeys(names) if n != water.path_model)


def supported(objectives: np.ndarray):
    """(best index (N,), supported mask (N, K)) from the candidates' objectives (N, K)."""
    f = np.where(np.isfinite(objectives), objectives, np.inf)
    best = np.argmin(f, axis=1)
    fb = f[np.arange(f.shape[0]), best]
    return best, f - fb[:, None] < PATH_MODEL_DELTA


def _union(cis, ok):
    """(N, 2) union of the intervals (K, N, 2) of the supported candidates ``ok`` (N, K)."""
    lo = np.where(ok.T, cis[..., 0], np.inf).min(axis=0)
    hi = np.where(ok.T, cis[..., 1], -np.inf).max(axis=0)
    return np.column_stack([lo, hi])


def combine_batch(results: dict):
    """One :class:`sca.BatchEstimate` from the candidates' (``results``: name -> estimate, the
    water's own model first): per chart the best model's estimate, intervals spanning the
    supported models.

    Parameters
    ----------
    results : dict
        Path model name -> BatchEstimate of the same charts.

    Returns
    -------
    BatchEstimate
        With ``path_model`` (N,) the chosen model, ``path_models`` (N,) tuples of the
        supported ones and ``path_objective`` {name: (N,)}.
    """
    names = list(results)
    ests = [results[n] for n in names]
    N = len(ests[0])
    rows = np.arange(N)
    obj = np.column_stack([e.objective for e in ests]) if N else np.zeros((0, len(names)))
    best, ok = supported(obj)

    def pick(arrs):
        stack = np.stack([np.asarray(a) for a in arrs])
        return stack[best, rows]
    fields = {}
    for f in dataclasses.fields(ests[0]):
        vals = [getattr(e, f.name) for e in ests]
        if isinstance(vals[0], np.ndarray) and vals[0].shape[:1] == (N,) and f.name != "wavelengths":
            fields[f.name] = pick(vals)
        else:
            fields[f.name] = vals[0]
    fields["values"] = {k: pick([e.values[k] for e in ests]) for k in ests[0].values}
    ints = {k: _union(np.stack([e.intervals[k] for e in ests]), ok) for k in ests[0].intervals}
    fields["intervals"] = ints
    for k in ("chl", "cdom"):
        if k in ints:
            fields[f"{k}_ci"] = ints[k]
    flags = []
    for i in range(N):
        f = list(ests[best[i]].flags[i])
        for j in np.flatnonzero(ok[i]):
            f += [x for x in ests[j].flags[i] if x in _INTERVAL_FLAGS]
        if ok[i].sum() > 1:
            f.append(SPAN_FLAG)
        flags.append(tuple(dict.fromkeys(f)))
    fields["flags"] = flags
    fields["reliable"] = np.array([not any(x in BLOCKING for x in f) for f in flags], bool)
    qi = {k: _union(np.stack([e.quantity_intervals[k] for e in ests]), ok)
          for k in ests[0].quantity_intervals}
    fields["quantity_intervals"] = qi
    fields["quantities"] = {k: pick([e.quantities[k] for e in ests]) for k in ests[0].quantities}
    if ests[0].beam_attenuation_ci is not None:
        cis = np.stack([e.beam_attenuation_ci for e in ests])  # (K, N, q, 2)
        okq = ok.T[:, :, None]
        fields["beam_attenuation_ci"] = np.stack(
            [np.where(okq, cis[..., 0], np.inf).min(axis=0),
             np.where(okq, cis[..., 1], -np.inf).max(axis=0)], axis=-1)

    fields["verdicts"] = verdicts_of(fields["chl_ci"], fields["cdom_ci"], qi)
    fields["budget"] = {k: {"sd": pick([e.budget[k]["sd"] for e in ests]),
                            "shares": {s: pick([e.budget[k]["shares"].get(s, np.full(N, np.nan))
                                                for e in ests])
                                       for s in ests[0].budget[k]["shares"]}}
                        for k in ests[0].budget if all(k in e.budget for e in ests)}
    out = type(ests[0])(**fields)
    out.path_model = np.array(names)[best] if N else np.zeros(0, str)
    out.path_models = [tuple(np.array(names)[ok[i]]) for i in range(N)]
    out.path_objective = {n: obj[:, j] for j, n in enumerate(names)}
    return out


def combine_single(results: dict):
    """One :class:`sca.Estimate` from the candidates' (name -> Estimate, the water's own model
    first); see :func:`combine_batch`. Of a candidate the data do not support only the
    ``objective`` and the ``consistency`` are read (a :class:`sca.verdict.Settled` fit will
    do); of a supported one but the best only the intervals and their flags."""
    names = list(results)
    ests = [results[n] for n in names]
    obj = np.array([[e.objective for e in ests]])
    best, ok = supported(obj)
    b = ests[int(best[0])]
    sup = [ests[j] for j in np.flatnonzero(ok[0])]

    def span(get):
        cis = [get(e) for e in sup]
        return (float(min(c[0] for c in cis)), float(max(c[1] for c in cis)))
    ints = {k: span(lambda e, k=k: e.intervals[k]) for k in b.intervals
            if all(k in e.intervals for e in sup)}
    flags = list(b.flags)
    for e in sup:
        flags += [x for x in e.flags if x in _INTERVAL_FLAGS]
    if len(sup) > 1:
        flags.append(SPAN_FLAG)
    consistency, table = finalize_single(ests, int(best[0]))
    flags = add_flags(tuple(dict.fromkeys(flags)), table)
    qi = {k: span(lambda e, k=k: e.quantity_intervals[k]) for k in b.quantity_intervals
          if all(k in e.quantity_intervals for e in sup)}
    cci = b.beam_attenuation_ci
    if cci is not None and all(e.beam_attenuation_ci is not None for e in sup):
        cci = np.stack([np.min([e.beam_attenuation_ci[:, 0] for e in sup], axis=0),
                        np.max([e.beam_attenuation_ci[:, 1] for e in sup], axis=0)], axis=-1)

    chl_ci, cdom_ci = ints.get("chl", b.chl_ci), ints.get("cdom", b.cdom_ci)
    verdicts = {"chl": verdict(*chl_ci), "cdom": verdict(*cdom_ci),
                **{k: verdict(*v, k) for k, v in qi.items()}}
    return dataclasses.replace(
        b, chl_ci=chl_ci, cdom_ci=cdom_ci, quantity_intervals=qi, beam_attenuation_ci=cci,
        verdicts=verdicts, intervals={**b.intervals, **ints}, flags=flags,
        consistency=consistency,
        reliable=not any(x in BLOCKING for x in flags),
        path_models=tuple(names[j] for j in np.flatnonzero(ok[0])),
        path_objective={n: float(e.objective) for n, e in zip(names, ests)})
