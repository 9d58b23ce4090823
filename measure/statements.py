"""What a fit measures, in words: one sentence per reported quantity (:func:`statements`), the
same verdicts (:func:`sca.derived.verdict`) the results carry, for the command line, report.png
and the JSON files.

The quantities: C and a_CDOM(440) (the model's parameters), and what the photos measure best
(:mod:`sca.derived`): the attenuation coefficient of the light's path at 443, 490, 555 and
670 nm, the optical depth of the path tau = c (depth + distance) at the same bands
(dimensionless; a single photo's: a dive's joint estimate does not report it) and the non-water
absorption a_nw(440).
"""

from __future__ import annotations

import math

from sca.derived import OPTICAL_DEPTH, QUANTITIES, VERDICTS, describe, verdict
from forward.errors import InputError

__all__ = ["GROUPS", "HINTS", "LABELS", "consistency_lines", "estimate_values", "one_line", "statements"]

#: name -> (label for people, units) of every reported quantity, in the order they are said.
LABELS = {"chl": ("C", "mg m^-3"), "cdom": ("a_CDOM(440)", "m^-1"),
          **{k: ((f"tau({v[1]:.0f})", "") if v[0] == OPTICAL_DEPTH else
                 (f"c({v[1]:.0f})" if k.startswith("c_") else
                  {"a_nw_440": "a_nw(440)"}.get(k, k), "m^-1"))
             for k, v in QUANTITIES.items()}}
#: How :func:`one_line` names each verdict's group (:data:`sca.derived.VERDICTS`).
GROUPS = {"measured": "measured", "loosely measured": "loosely measured",
          "upper bound": "only an upper bound", "not constrained": "not constrained"}
#: What would narrow C and a_CDOM when the data leave them open: where ('photo', 'chart',
#: 'dive') -> name -> [(the auxiliary measurement it needs not to have been given, or None;
#: the advice)], joined with 'or'.
HINTS = {
    "photo": {"chl": [(None, "a dive fitted with --joint"),
                      ("cdom", "a measured CDOM (--cdom-sample)")],
              "cdom": [("cdom", "a water sample's a_CDOM (--cdom-sample)")]},
    "chart": {"chl": [("cdom", "a measured CDOM (--cdom-sample)")],
              "cdom": [("cdom", "a water sample's a_CDOM (--cdom-sample)")]},
    "dive": {"chl": [("cdom", "a measured CDOM (a cdom_sample column, or --cdom-sample)")],
             "cdom": [("cdom", "a water sample's a_CDOM (a cdom_sample column, or "
                               "--cdom-sample)")]},
}


def _hint(where, name, given) -> str:
    """The advice of :data:`HINTS` for ``name``, without what was already given."""
    ways = [text for need, text in HINTS[where].get(name, []) if need not in given]
    return f"{', or '.join(ways)}, narrows it" if len(ways) > 1 else (
        f"{ways[0]} narrows it" if ways else "")


def _end(v) -> float:
    """An interval end as a float (JSON's "inf" and None included)."""
    if v is None:
        return math.nan
    return float(v)


def estimate_values(result) -> tuple:
    """(values, intervals) of every reported quantity of a result.

    Parameters
    ----------
    result : sca.Estimate, sca.joint.JointEstimate or dict
        A fit, or the ``estimate`` of measurement.json / joint.json's content (``chl``,
        ``chl_ci``, ``cdom``, ``cdom_ci``, ``quantities``, ``quantity_intervals``).

    Returns
    -------
    values : dict
        name -> float, in :data:`LABELS`' order (those the result has).
    intervals : dict
        name -> (lo, hi) (``inf``: open).
    """
    get = result.get if isinstance(result, dict) else (lambda k, d=None: getattr(result, k, d))
    values = {"chl": float(get("chl")), "cdom": float(get("cdom"))}
    intervals = {"chl": tuple(_end(v) for v in get("chl_ci")),
                 "cdom": tuple(_end(v) for v in get("cdom_ci"))}
    q, qi = get("quantities") or {}, get("quantity_intervals") or {}
    for k in LABELS:
        if k in q and k in qi:
            values[k] = float(q[k])
            intervals[k] = tuple(_end(v) for v in qi[k])
    return values, intervals


def statements(result, where: str = "photo", given=()) -> list:
    """One plain sentence per reported quantity: measured, loosely measured, only an upper
    bound, or not constrained (:func:`sca.derived.describe`), with what would narrow C and a_CDOM; then
    a sentence per reading or prior that contradicts the photos (:func:`consistency_lines`).

    Parameters
    ----------
    result : sca.Estimate, sca.joint.JointEstimate or dict
        As :func:`estimate_values`.
    where : {'photo', 'chart', 'dive'}, optional
        What was measured (the sentences say 'this photo', ...).
    given : iterable of str, optional
        The auxiliary measurements fused in the fit ('cdom', 'secchi', 'kd'): the advice does
        not suggest them again.

    Returns
    -------
    list of str

    Raises
    ------
    ValueError
        Naming ``where`` when it is not one of :data:`HINTS`.
    """
    if where not in HINTS:
        raise InputError("where", f"must be one of {tuple(HINTS)}, got {where!r}")
    values, intervals = estimate_values(result)
    given = set(given)
    out = []
    for k, v in values.items():
        label, units = LABELS[k]
        lo, hi = intervals[k]
        out.append(describe(label, v, lo, hi, units, where=f"this {where}",
                            narrow=_hint(where, k, given), name=k))
    return out + consistency_lines(result)


def one_line(result, names=None) -> str:
    """Reported quantities on one line, grouped by verdict (:data:`GROUPS`): 'measured: C 1.2
    [0.7, 2.1] mg m^-3, c(490) 0.21 [0.2, 0.22] m^-1, ...; loosely measured: -; only an upper
    bound: a_CDOM(440) <= 0.3 m^-1; not constrained: -'.

    Parameters
    ----------
    result : sca.Estimate, sca.joint.JointEstimate or dict
        As :func:`estimate_values`.
    names : iterable of str, optional
        The quantities to say (names of :data:`LABELS`); default every one the result has.

    Returns
    -------
    str
    """
    values, intervals = estimate_values(result)
    if names is not None:
        values = {k: v for k, v in values.items() if k in set(names)}
    groups = {kind: [] for kind in VERDICTS}
    for k, v in values.items():
        label, units = LABELS[k]
        u = f" {units}" if units else ""
        lo, hi = intervals[k]
        kind = verdict(lo, hi, k)
        if kind in ("measured", "loosely measured"):
            groups[kind].append(f"{label} {v:.3g} [{lo:.3g}, {hi:.3g}]{u}")
        elif kind == "upper bound":
            groups[kind].append(f"{label} <= {hi:.3g}{u}")
        else:
            groups[kind].append(f"{label} >= {lo:.3g}{u}")
    return "; ".join(f"{GROUPS[kind]}: {', '.join(items) or '-'}"
                     for kind, items in groups.items())


def consistency_lines(result) -> list:
    """What the tests of the readings and priors against the photos found, in words: a line per
    reading in conflict and per nuisance pulled beyond its threshold (:mod:`sca.consistency`);
    none where everything agrees.

    Parameters
    ----------
    result : sca.Estimate or sca.joint.JointEstimate
        Its ``consistency`` ({} where nothing was tested).

    Returns
    -------
    list of str

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> r = SimpleNamespace(consistency={"readings": {"cdom": {"delta_chi2": 19.3, "p": 1.1e-5,
    ...     "conflict": True}}, "pulls": {"cdom_slope": -3.6}, "pull_max": 3.5,
    ...     "conflict_p": 1e-3})
    >>> for line in consistency_lines(r):
    ...     print(line)
    the reading cdom contradicts the photos (Delta chi^2 19.3, p 1.1e-05): not reliable, and every number fused with it suspect
    the budget's cdom_slope is pulled -3.6 of its prior's sds (beyond 3.5): a prior bent to fit
    """
    c = (result.get("consistency") if isinstance(result, dict)
         else getattr(result, "consistency", None)) or {}
    out = [f"the reading {k} contradicts the photos (Delta chi^2 {v['delta_chi2']:.3g}, p "
           f"{v['p']:.2g}): not reliable, and every number fused with it suspect"
           for k, v in c.get("readings", {}).items() if v["conflict"]]
    out += [f"the budget's {k} is pulled {v:+.2g} of its prior's sds (beyond "
            f"{c['pull_max']:g}): a prior bent to fit"
            for k, v in c.get("pulls", {}).items() if abs(v) > c.get("pull_max", math.inf)]
    return out
