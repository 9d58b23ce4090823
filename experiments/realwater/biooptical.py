"""The Case-1 relation prior learned on NOMAD's even rows: ``data/case1_relations_nomad_even.csv``.

``python -m experiments.realwater.biooptical`` learns a_CDOM(440) = alpha C^beta,
a_NAP(440) = gamma C^delta and a_phi(440) = A C^B (:func:`sca.biooptical.fit_relation`: least
squares in logs, the residual's sd the scatter) on the EVEN data rows of the NOMAD stations of the K_d comparison
(:func:`experiments.realwater.nomad_data.load_nomad`: >= 5 K_d bands and in-situ C), and writes the
table that :mod:`sca.biooptical` reads. ``--check`` only compares the table with what the even
rows give (exit 1 when they differ). The odd rows are never read here: they test the prior
(:mod:`experiments.realwater.nomad`, REALWATER.md).

Columns of NOMAD used: ``ag443`` (a_CDOM(443), taken to 440 nm by eq 6 with the paper's slope
0.014 nm^-1), ``ad443`` (a_NAP(443), taken to 440 nm by eq 7 with 0.011 nm^-1), ``ap443 -
ad443`` (a_phi(443), taken to 440 nm by the model's phytoplankton shape), and C (HPLC ``chl_a``
where present, else fluorometric ``chl``). :func:`held_out` tests the relations on the odd
rows.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import forward
from sca.biooptical import CASE1_QUANTITIES, CASE1_TABLE, fit_relation, read_case1

from .nomad_data import NomadStations, cdom_440, load_nomad

__all__ = ["CHECK_RTOL", "CHL_FLOOR", "COMMAND", "FLOOR", "TABLE_PATH", "agrees", "fit_relations",
           "held_out", "learn_relations", "main", "measured_440", "nap_440", "phyto_440",
           "table_text", "tested_on", "training_rows"]

#: The command that writes the table (named in its header).
COMMAND = "python -m experiments.realwater.biooptical"
#: Added to a_q before the logarithm, m^-1: below every NOMAD ag443 and ad443 but one (keeps the
#: prior's h finite where a fit puts a_CDOM at 0).
FLOOR = 1e-4
#: Added to C before the logarithm, mg m^-3: a tenth of NOMAD's smallest C (0.012).
CHL_FLOOR = 1e-3
#: The table in the repository's ``data/``.
TABLE_PATH = Path(__file__).resolve().parents[2] / "data" / CASE1_TABLE
#: A relation's constants are reproduced by the table when they agree to this relative tolerance
#: (the table holds 4 significant digits).
CHECK_RTOL = 5e-4


def training_rows(st: NomadStations) -> NomadStations:
    """The stations of even data rows: the only ones the prior is learned on."""
    return st.subset(np.flatnonzero(st.station % 2 == 0))


def nap_440(ad443, water=None) -> np.ndarray:
    """a_NAP(440) from a measured a_NAP(443) through eq 7 with the water's slope, m^-1."""
    shape = forward.nap_absorption(np.array([440.0, 443.0, 446.0]), 1.0, water=water)[1]
    return np.asarray(ad443, float) / (shape / forward.nap_absorption_440(1.0, water=water))


def phyto_440(aph443, water=None) -> np.ndarray:
    """a_phi(440) from a measured a_phi(443) through the model's phytoplankton shape, m^-1."""
    grid = np.array([440.0, 443.0, 446.0])
    shape = forward.phytoplankton_absorption(grid, 1.0, water=water)
    return np.asarray(aph443, float) * shape[0] / shape[1]


def measured_440(st: NomadStations, water=None) -> dict:
    """The stations' measured a_CDOM(440), a_NAP(440) and a_phi(440), m^-1 (NaN: not measured),
    from NOMAD's ``ag443``, ``ad443`` and ``ap443 - ad443``."""
    return {"cdom": cdom_440(st.ag443, water), "nap": nap_440(st.ad443, water),
            "phyto": phyto_440(st.aph443, water)}


def held_out(st: NomadStations, relations: dict, water=None) -> dict:
    """The relations tested on the ODD rows (:func:`tested_on`)."""
    return tested_on(st.subset(np.flatnonzero(st.station % 2 == 1)), relations, water)


def tested_on(test: NomadStations, relations: dict, water=None) -> dict:
    """The relations tested on the stations ``test``: the residual ln(a + floor) - ln alpha -
    beta ln(C + chl_floor) of the measured a_q(440).

    Returns
    -------
    dict
        quantity -> {'n', 'median' (the residual's median: the relation's bias there), 'sd'
        (its standard deviation), 'within' (share with |residual| <= 1.96 sd_learned: 0.95
        if the learned scatter holds)}.
    """
    values = measured_440(test, water)
    out = {}
    for q, r in relations.items():
        ok = np.isfinite(values[q])
        res = (np.log(values[q][ok] + r.floor) - np.log(r.alpha)
               - r.beta * np.log(test.chl[ok] + r.chl_floor))
        out[q] = {"n": int(ok.sum()), "median": float(np.median(res)),
                  "sd": float(np.std(res, ddof=1)),
                  "within": float(np.mean(np.abs(res) <= 1.959964 * r.sd))}
    return out


def learn_relations(st: NomadStations, water=None) -> dict:
    """The relations learned on the even rows of ``st`` (the shipped table's rows).

    Parameters
    ----------
    st : NomadStations
        All the K_d stations (the odd rows are dropped here).
    water : forward.Water, optional
        Its slopes take ag443 and ad443 to 440 nm (default: the paper's).

    Returns
    -------
    dict
        quantity -> :class:`sca.biooptical.Relation`.
    """
    return fit_relations(training_rows(st), water)


def fit_relations(train: NomadStations, water=None) -> dict:
    """The relations learned on every station of ``train`` (e.g. the training cruises of
    :func:`experiments.realwater.split.cruise_split`): quantity -> :class:`Relation`."""
    values = measured_440(train, water)
    return {q: fit_relation(q, train.chl, values[q], floor=FLOOR, chl_floor=CHL_FLOOR)
            for q in CASE1_QUANTITIES}


def table_text(relations: dict) -> str:
    """The CSV text of ``data/case1_relations_nomad_even.csv``."""
    lines = [
        "# Case-1 relation prior: ln(a_q(440) + floor) = ln alpha + beta ln(C + chl_floor) + e,"
        " e ~ N(0, sd_ln^2)",
        "# Source: fitted on NASA NOMAD v2 (Werdell & Bailey 2005, Remote Sens. Environ. 98:122;"
        " file nomad_seabass_v2.a_2008200),",
        "#   EVEN data rows of the stations with >= 5 K_d bands and in-situ C, by "
        f"`{COMMAND}`",
        "#   (least squares in logs; sd_ln = residual sd, n - 2 dof). cdom: ag443 taken to 440 nm"
        " by eq 6 (slope 0.014 nm^-1);",
        "#   nap: ad443 taken to 440 nm by eq 7 (0.011 nm^-1); phyto: ap443 - ad443 taken to 440"
        " nm by the phytoplankton shape of eq 9;",
        "#   C: HPLC chl_a, else fluorometric chl. The odd rows test it (REALWATER.md).",
        "# Used in: sca/biooptical.py (auxiliary={'case1': True}; the nap and phyto relations act"
        " where eq 8's / eq 10's scales are free,",
        "#   sca.biooptical.CASE1_UNCERTAIN); a choice for Case-1-like water, never a default.",
        "# Units: alpha_per_m and floor_per_m in m^-1 (alpha = a_q(440) at C = 1 mg m^-3); beta,"
        " sd_ln dimensionless; chl_floor_mg_m3 in mg m^-3",
        "# Grid: none (constants at 440 nm)",
        "quantity,alpha_per_m,beta,sd_ln,floor_per_m,chl_floor_mg_m3,n_stations",
    ]
    for q, r in relations.items():
        lines.append(f"{q},{r.alpha:.4g},{r.beta:.4g},{r.sd:.4g},{r.floor:g},{r.chl_floor:g},"
                     f"{r.n}")
    return "\n".join(lines) + "\n"


def agrees(learned: dict, table: dict) -> bool:
    """The table holds the learned constants (to :data:`CHECK_RTOL`) and the same counts."""
    for q, r in learned.items():
        t = table.get(q)
        if t is None or t.n != r.n or t.floor != r.floor or t.chl_floor != r.chl_floor:
            return False
        if not np.allclose([t.alpha, t.beta, t.sd], [r.alpha, r.beta, r.sd], rtol=CHECK_RTOL,
                           atol=0):
            return False
    return True


def main(argv=None) -> int:
    """Learn the relations on the even rows and write (or ``--check``) the table."""
    ap = argparse.ArgumentParser(prog=COMMAND, description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true",
                    help="compare the table with the even rows; exit 1 when they differ")
    args = ap.parse_args(argv)
    try:
        st = load_nomad()
    except FileNotFoundError as exc:
        print(f"real data absent: {exc}", file=sys.stderr)
        return 2
    learned = learn_relations(st)
    if args.check:
        ok = agrees(learned, read_case1())
        print("table agrees with the even rows" if ok else
              f"table differs from the even rows: run `{COMMAND}`", file=sys.stderr)
        return 0 if ok else 1
    TABLE_PATH.write_text(table_text(learned), encoding="utf-8")
    print(f"wrote {TABLE_PATH}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
