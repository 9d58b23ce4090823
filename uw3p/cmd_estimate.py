"""``uw3p estimate``: the water (C, CDOM, attenuation) from a chart's 24 patch values.

    uw3p estimate m.csv --depth 10 --distance 5 [--json] [--spectrum c.csv] [--mode safeguarded]
                  [--saturation S] [--gain free] [--fix-backscatter S] [--fix-cdom A]
                  [--cdom-sample VALUE:SD] [--secchi DEPTH:SD] [--kd NM=VALUE:SD ...]
    uw3p estimate --batch charts.csv [--depth D] [--distance R] [--json] [--spectrum c.csv]

One chart is fitted by ``sca.estimate`` (``mode='lm'`` unless ``--mode`` says otherwise), a batch (``--batch``) by ``sca.estimate_batch`` (in
blocks, with a progress bar on stderr, when it is big). The patch CSV conventions are those of
:mod:`uw3p.patchfile`. The default output is the result, its uncertainty budget and what the
chart measures in words (measured, loosely measured, only an upper bound, not constrained:
C, a_CDOM(440), the attenuation coefficient of the light's path at 443, 490, 555 and 670 nm,
the path's optical depth tau there (dimensionless), a_nw(440));
the coefficient's spectrum c(lambda) with its 95 % interval and the transmittance k(lambda) are
in ``--json`` and in the ``--spectrum`` file. Measurements of the water besides the chart
(``--cdom-sample``, ``--secchi``, ``--kd``) are fused in the fit. Exit status 0 when every
estimate is reliable, 1 when one is not (its flags say why).
"""

from __future__ import annotations

import json
import math
import re

from measure.csvsafe import safe_writer

from forward.errors import InputError

from .common import (EXIT_NOT_RELIABLE, EXIT_OK, add_auxiliary_options, add_budget_options,
                     add_setup_options, atomic_open, auxiliary_from_args, budget_text, camera_note,
                     check_spectra_args, json_text, setup_kwargs, uncertain_from_args)

__all__ = ["NAME", "BUFFERED", "BATCH_COLUMNS", "FIT_BLOCK", "PROGRESS_CHARTS",
           "PROGRESS_BYTES", "QUANTITY_NAMES", "add_parser", "run"]

#: The subcommand's name.
NAME = "estimate"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True
#: The quantities of :data:`sca.derived.QUANTITIES` (what a chart measures: c and a_nw in
#: m^-1, the optical depth tau dimensionless), as named in the outputs (plain data: the
#: command's help imports no numpy).
QUANTITY_NAMES = ("c_443", "c_490", "c_555", "c_670", "tau_443", "tau_490", "tau_555",
                  "tau_670", "a_nw_440")
#: Columns of the batch output (one row per chart), ``backscatter_<j>`` one per channel; after
#: the earlier 22: the verdicts of C and a_CDOM and, for every quantity of
#: :data:`QUANTITY_NAMES`, its value, 95 % interval and verdict (m^-1; tau dimensionless).
BATCH_COLUMNS = ("chart", "chl", "chl_lo", "chl_hi", "cdom", "cdom_lo", "cdom_hi", "reliable",
                 "flags", "fit_rms", "chi2_dof", "backscatter_*", "gain", "gain_lo", "gain_hi",
                 "objective", "converged", "iterations", "status", "depth_m", "distance_m",
                 "chl_budget", "chl_verdict", "cdom_verdict") + tuple(
                     f"{q}{end}" for q in QUANTITY_NAMES for end in ("", "_lo", "_hi",
                                                                     "_verdict"))
#: A big batch is fitted this many charts per call of ``sca.estimate_batch`` (the progress
#: bar's step; every chart's fit is independent of the others').
FIT_BLOCK = 4096
#: A batch of at least this many charts shows a progress bar of its fit on stderr...
PROGRESS_CHARTS = 2 * FIT_BLOCK
#: ... and a file of at least this many bytes one of its reading.
PROGRESS_BYTES = 20_000_000


def add_parser(sub):
    """Register ``estimate`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="estimate C, CDOM and attenuation from patch values")
    p.add_argument("measurements", nargs="?", default=None,
                   help="CSV with columns patch, red, green, blue [, red_sd, green_sd, blue_sd] "
                        "(one row per patch; R, G, B also; any order; comma, semicolon or tab; "
                        "decimal comma with semicolons)")
    p.add_argument("--batch", default=None, metavar="FILE",
                   help="many charts at once (sca.estimate_batch): CSV with columns chart, patch, "
                        "red, green, blue [, *_sd] [, depth_m, distance_m]; one output row per "
                        "chart")
    p.add_argument("--depth", type=float, default=None,
                   help="chart depth, m (a batch: unless the file has a depth_m column)")
    p.add_argument("--distance", type=float, default=None,
                   help="camera-to-chart distance, m (a batch: unless the file has a distance_m "
                        "column)")
    p.add_argument("--mode", default=None, choices=["lm", "safeguarded", "paper"],
                   help="single chart only: lm (default), the batch's Levenberg-Marquardt on the "
                        "chart, which reaches the DPP loop's optimum; safeguarded or paper, the "
                        "paper's convex loop in cvxpy")
    p.add_argument("--max-iter", type=int, default=100)
    p.add_argument("--fix-backscatter", type=float, default=None, help="hold s fixed (e.g. 0)")
    p.add_argument("--fix-cdom", type=float, default=None, help="hold a_CDOM(440) fixed, m^-1")
    p.add_argument("--saturation", type=float, default=None,
                   help="the sensor's clip level in the data's units (values there are flagged)")
    p.add_argument("--json", action="store_true",
                   help="print the whole result as JSON (the spectra, the quantities with their "
                        "intervals and verdicts, and the statements in words included)")
    p.add_argument("--spectrum", default=None, metavar="FILE",
                   help="write the attenuation coefficient of the light's path c(lambda) (m^-1) "
                        "with its 95 %% interval, and the transmittance k = exp(-(depth + "
                        "distance) c), to this CSV: wavelength_nm, c_per_m, c_lo_per_m, "
                        "c_hi_per_m, transmittance (a batch: one row per chart, columns c_<nm>, "
                        "c_lo_<nm>, c_hi_<nm>, transmittance_<nm>)")
    p.add_argument("--attenuation", default=None, metavar="FILE",
                   help="(kept for scripts; prefer --spectrum) the transmittance k(lambda) "
                        "alone, dimensionless: wavelength_nm, attenuation_k (a batch: one "
                        "column k_<nm> per wavelength)")
    p.add_argument("--gain", default="known", choices=["known", "free"],
                   help="known: values in model units (as simulate writes them); free: any units "
                        "(e.g. raw camera values), one unknown exposure gain fitted with the water")
    add_setup_options(p)
    add_budget_options(p)
    add_auxiliary_options(p)
    p.set_defaults(func=run)
    return p


def _ci(ci):
    return [float(ci[0]), float(ci[1])]


def _interval_text(ci, unit):
    hi = "inf" if not math.isfinite(ci[1]) else f"{ci[1]:.4g}"
    return f"95 % interval [{ci[0]:.4g}, {hi}] {unit}"


# --------------------------------------------------------------------------- batch
_CHARTS = re.compile(r"charts? ((?:\d+, )*\d+)(, \.\.\.)? \(0-based\)")


def _chart_ids(msg: str, charts, offset: int) -> str:
    """``sca.estimate_batch``'s 'chart 3 (0-based)' said with the file's chart ids."""
    def ids(m):
        idx = [int(i) + offset for i in m.group(1).split(", ")]
        names = ", ".join(repr(charts[i]) for i in idx if i < len(charts))
        return f"chart{'s' if len(idx) > 1 else ''} {names}{m.group(2) or ''}"
    return _CHARTS.sub(ids, msg)


def _batch_error(exc, args, charts, offset):
    """A ``sca.estimate_batch`` error in the command's terms: the file and its chart ids."""
    argument = getattr(exc, "argument", None)
    if argument is None:  # not an input error: said as it is
        return exc
    where = {"rgb_stack": f"{args.batch}: ", "sigma": f"{args.batch}: the _sd columns: "}
    if argument not in where:  # the option is named from the argument (uw3p.cli)
        return InputError(argument, _chart_ids(exc.reason, charts, offset))
    return InputError("--batch", where[argument] + _chart_ids(exc.reason, charts, offset))


def _geometry(args, depth, distance):
    """Per-chart depth and distance: the file's column or the option, never both."""
    import numpy as np

    for name, arr, opt in (("depth", depth, args.depth), ("distance", distance, args.distance)):
        if not np.isnan(arr).all():  # the file has a <name>_m column
            if opt is not None:
                raise InputError(f"--{name}", f"{args.batch} has a {name}_m column (one {name} per "
                                 f"chart); give the {name} in the file or with --{name}, not both")
        elif opt is None:
            raise InputError(f"--{name}", f"required unless the batch file has a {name}_m column")
        else:
            arr[:] = opt
    return depth, distance


def _quantity_cells(res, j):
    """The batch row's cells of the verdicts and quantities of chart ``j``."""
    cells = [str(res.verdicts["chl"][j]), str(res.verdicts["cdom"][j])]
    for q in QUANTITY_NAMES:
        ci = res.quantity_intervals[q][j]
        cells += [repr(float(res.quantities[q][j])), repr(float(ci[0])), repr(float(ci[1])),
                  str(res.verdicts[q][j])]
    return cells


def _batch_rows(res, charts, depth, distance, lo):
    """The output rows (lists) of a block of charts starting at ``lo``."""
    budget = res.budget.get("chl", {}).get("shares", {})
    for j in range(len(res)):
        shares = {k: float(v[j]) for k, v in budget.items()}
        yield ([charts[lo + j], repr(float(res.chl[j])), repr(float(res.chl_ci[j, 0])),
                repr(float(res.chl_ci[j, 1])), repr(float(res.cdom[j])),
                repr(float(res.cdom_ci[j, 0])), repr(float(res.cdom_ci[j, 1])),
                bool(res.reliable[j]), " ".join(res.flags[j]), repr(float(res.fit_rms[j])),
                repr(float(res.chi2_dof[j]))]
               + [repr(float(v)) for v in res.backscatter[j]]
               + [repr(float(res.gain[j])), repr(float(res.gain_ci[j, 0])),
                  repr(float(res.gain_ci[j, 1])), repr(float(res.objective[j])),
                  bool(res.converged[j]), int(res.iterations[j]), str(res.status[j]),
                  repr(float(depth[lo + j])), repr(float(distance[lo + j])),
                  budget_text({"chl": {"shares": shares}}, "chl")] + _quantity_cells(res, j))


def _batch_records(res, charts, depth, distance, lo):
    """The ``--json`` records of a block of charts starting at ``lo``."""
    for j in range(len(res)):
        yield dict(chart=charts[lo + j], chl=float(res.chl[j]), cdom=float(res.cdom[j]),
                   chl_ci=_ci(res.chl_ci[j]), cdom_ci=_ci(res.cdom_ci[j]),
                   reliable=bool(res.reliable[j]), flags=list(res.flags[j]),
                   fit_rms=float(res.fit_rms[j]), chi2_dof=float(res.chi2_dof[j]),
                   chi2_p=float(res.chi2_p[j]), dof=int(res.dof[j]),
                   backscatter=res.backscatter[j].tolist(), gain=float(res.gain[j]),
                   gain_ci=_ci(res.gain_ci[j]), attenuation=res.attenuation[j].tolist(),
                   objective=float(res.objective[j]), converged=bool(res.converged[j]),
                   iterations=int(res.iterations[j]), status=str(res.status[j]),
                   depth=float(depth[lo + j]), distance=float(distance[lo + j]),
                   budget={k: {"sd": float(v["sd"][j]),
                               "shares": {s: float(x[j]) for s, x in v["shares"].items()}}
                           for k, v in res.budget.items()},
                   quantities={q: float(res.quantities[q][j]) for q in res.quantities},
                   quantity_intervals={q: _ci(res.quantity_intervals[q][j])
                                       for q in res.quantity_intervals},
                   verdicts={q: str(v[j]) for q, v in res.verdicts.items()},
                   beam_attenuation=res.beam_attenuation[j].tolist(),
                   beam_attenuation_ci=res.beam_attenuation_ci[j].tolist())


def _spectrum_header(wavelengths, batch: bool):
    """The ``--spectrum`` file's header."""
    if not batch:
        return ["wavelength_nm", "c_per_m", "c_lo_per_m", "c_hi_per_m", "transmittance"]
    return ["chart"] + [f"{name}_{w:g}" for name in ("c", "c_lo", "c_hi", "transmittance")
                        for w in wavelengths]


def _spectrum_rows(c, ci, k, wavelengths):
    """The single chart's ``--spectrum`` rows: per wavelength c, its interval and k."""
    for w, v, (lo, hi), t in zip(wavelengths, c, ci, k):
        yield [f"{w:g}", repr(float(v)), repr(float(lo)), repr(float(hi)), repr(float(t))]


def _auxiliary(args, sigma) -> dict:
    """The auxiliary measurements of the options; refused without the patches' noise."""
    aux = auxiliary_from_args(args)
    if aux and sigma is None:
        given = ", ".join(o for o, k in (("--cdom-sample", "cdom"), ("--secchi", "secchi"),
                                          ("--kd", "kd")) if k in aux)
        raise InputError(given.split(", ")[0], f"a measurement is weighed against the patches' "
                         "noise: the patch file needs its _sd columns (red_sd, green_sd, "
                         f"blue_sd) to fuse {given}")
    return aux


def _run_batch(args, out, err):
    import contextlib
    import os

    import numpy as np

    from sca import estimate_batch
    from tqdm import tqdm

    from .patchfile import read_batch_csv

    if args.mode is not None:
        raise InputError("--mode", "the batched solver (--batch) has one algorithm (variable "
                         "projection + Levenberg-Marquardt); omit --mode")
    if args.fix_cdom is not None:
        raise InputError("--fix-cdom", "not available with --batch")
    big_file = os.path.isfile(args.batch) and os.path.getsize(args.batch) >= PROGRESS_BYTES
    charts, M, sigma, depth, distance = read_batch_csv(args.batch,
                                                       progress=err if big_file else None)
    depth, distance = _geometry(args, depth, distance)
    fix = {"backscatter": args.fix_backscatter} if args.fix_backscatter is not None else None
    aux = _auxiliary(args, sigma)
    kw = dict(saturation=args.saturation, fix=fix, max_iter=args.max_iter, gain=args.gain,
              uncertain=uncertain_from_args(args), auxiliary=aux or None, **setup_kwargs(args))
    err.write(camera_note(args.camera, kw["wavelengths"]))
    N = len(charts)
    step = FIT_BLOCK if N >= PROGRESS_CHARTS else max(N, 1)
    totals = {"converged": 0, "reliable": 0, "elapsed": 0.0}
    writer = safe_writer(out, lineterminator="\n")
    first = True
    with contextlib.ExitStack() as stack:
        kfile = (safe_writer(stack.enter_context(atomic_open(args.attenuation, "--attenuation")),
                             lineterminator="\n") if args.attenuation else None)
        cfile = (safe_writer(stack.enter_context(atomic_open(args.spectrum, "--spectrum")),
                             lineterminator="\n") if args.spectrum else None)
        bar = stack.enter_context(tqdm(total=N, file=err, desc="fitting", unit="chart",
                                       disable=N < PROGRESS_CHARTS, leave=False))
        for lo in range(0, N, step):
            hi = min(N, lo + step)
            try:
                res = estimate_batch(M[lo:hi], depth=depth[lo:hi], distance=distance[lo:hi],
                                     sigma=None if sigma is None else sigma[lo:hi], **kw)
            except ValueError as exc:
                raise _batch_error(exc, args, charts, lo) from None
            if first:
                m = M.shape[1]
                if args.json:
                    out.write('{\n "wavelengths": ' + json.dumps(res.wavelengths.tolist())
                              + ',\n "noise_known": ' + json.dumps(res.noise_known)
                              + ',\n "charts": [')
                else:
                    writer.writerow([c if c != "backscatter_*" else f"backscatter_{j}"
                                     for c in BATCH_COLUMNS
                                     for j in (range(m) if c == "backscatter_*" else [0])])
                if kfile is not None:
                    kfile.writerow(["chart"] + [f"k_{w:g}" for w in res.wavelengths])
                if cfile is not None:
                    cfile.writerow(_spectrum_header(res.wavelengths, batch=True))
            if args.json:
                for j, rec in enumerate(_batch_records(res, charts, depth, distance, lo)):
                    out.write(("\n" if first and j == 0 else ",\n")
                              + json_text(rec).rstrip("\n"))
            else:
                writer.writerows(_batch_rows(res, charts, depth, distance, lo))
            if kfile is not None:
                kfile.writerows([charts[lo + j]] + [repr(float(v)) for v in res.attenuation[j]]
                                for j in range(len(res)))
            if cfile is not None:
                cfile.writerows([charts[lo + j]] + [repr(float(v)) for v in np.concatenate([
                    res.beam_attenuation[j], res.beam_attenuation_ci[j, :, 0],
                    res.beam_attenuation_ci[j, :, 1], res.attenuation[j]])]
                    for j in range(len(res)))
            first = False
            totals["converged"] += int(res.converged.sum())
            totals["reliable"] += int(res.reliable.sum())
            totals["elapsed"] += res.elapsed_s
            bar.update(hi - lo)
    if args.json:
        out.write("\n ]\n}\n")
    for path in (args.attenuation, args.spectrum):
        if path:
            err.write(f"wrote {path}\n")
    err.write(f"{N} charts, {totals['converged']} converged, {totals['reliable']} reliable, "
              f"{totals['elapsed']:.3f} s\n")
    return EXIT_OK if totals["reliable"] == N else EXIT_NOT_RELIABLE


# --------------------------------------------------------------------------- one chart
def _summary(res, gain, given=()) -> str:
    """The default output of one chart: the result, its uncertainty budget and what the chart
    measures in words (:func:`measure.statements.statements`)."""
    from measure.statements import statements

    lines = [f"chl (C)          {res.chl:.6g} mg m^-3, {_interval_text(res.chl_ci, 'mg m^-3')}",
             f"cdom a_CDOM(440) {res.cdom:.6g} m^-1, {_interval_text(res.cdom_ci, 'm^-1')}",
             "backscatter s    " + " ".join(f"{v:.6g}" for v in res.backscatter)]
    if gain == "free":
        lines.append(f"gain             {res.gain:.6g}, {_interval_text(res.gain_ci, '')}"
                     "(data units per model unit)")
    chi2 = (f"chi2/dof {res.chi2_dof:.3g} (p = {res.chi2_p:.3g}, dof {res.dof})"
            if res.noise_known else "chi2 not tested: the noise is unknown")
    lines.append(f"fit              fit_rms {res.fit_rms:.3g}, {chi2}")
    if res.budget:
        for key, label, unit in (("chl", "C   ", "mg m^-3"), ("cdom", "CDOM", "m^-1")):
            if key in res.budget:
                lines.append(f"budget of {label}   sd {res.budget[key]['sd']:.3g} {unit}: "
                             f"{budget_text(res.budget, key)}")
    elif res.noise_known:
        lines.append("budget           none: the paper's exact model (--exact)")
    others = [m for m in res.path_models if m != res.path_model]
    if others:
        lines.append(f"path model       {res.path_model}; the data cannot tell it from "
                     f"{', '.join(others)}: the intervals span them")
    elif len(res.path_objective) > 1:
        lines.append(f"path model       {res.path_model}, chosen by the data over "
                     + ", ".join(m for m in res.path_objective if m != res.path_model))
    lines.append(f"reliable         {res.reliable}"
                 + (f" (flags: {', '.join(res.flags)})" if res.flags else ""))
    lines.append(f"converged        {res.converged} ({res.status}; {res.iterations} iterations, "
                 f"mode {res.mode}, path model {res.path_model})")
    if res.quantities:
        lines.append("what this chart measures (95 % intervals):")
        lines += [f"  {x}" for x in statements(res, "chart", given)]
    lines.append(f"spectrum         c(lambda) with its interval and the transmittance k on "
                 f"{res.wavelengths.size} wavelengths ({res.wavelengths[0]:g}-"
                 f"{res.wavelengths[-1]:g} nm): --json or --spectrum FILE")
    return "\n".join(lines) + "\n"


def run(args, out, err) -> int:
    """Estimate the water of one chart (``measurements``) or of a batch (``--batch``).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``measurements`` or ``batch`` (CSV files), ``depth`` (m), ``distance``
        (m), ``mode``, ``max_iter``, ``fix_backscatter``, ``fix_cdom`` (m^-1), ``saturation``
        (data units), ``json``, ``spectrum`` and ``attenuation`` (CSV files), ``gain``, the
        setup, the budget and the auxiliary measurements' options.
    out : text stream
        The estimate: C, a_CDOM(440), the backscatter, the fit, the uncertainty budget, the
        verdict and what the chart measures in words; a batch: one CSV row per chart
        (``BATCH_COLUMNS``, ids quoted as needed);
        ``--json``: every field, the attenuation spectrum included.
    err : text stream
        Notes, ``wrote <file>``, a big batch's progress and its one-line count of converged
        and reliable charts.

    Returns
    -------
    int
        ``EXIT_OK`` when every estimate is reliable, else ``EXIT_NOT_RELIABLE``.

    Raises
    ------
    ValueError
        Bad input; the message names the argument or file (and, in a batch, the chart).
    """
    from sca import estimate

    from .patchfile import read_patch_csv

    if (args.batch is None) == (args.measurements is None):
        raise InputError("measurements", "give either a measurements CSV or --batch FILE")
    check_spectra_args(args)
    if args.batch is not None:
        return _run_batch(args, out, err)
    if args.depth is None or args.distance is None:
        raise InputError("--depth, --distance", "both are required")
    M, sigma = read_patch_csv(args.measurements)
    fix = {}
    if args.fix_backscatter is not None:
        fix["backscatter"] = args.fix_backscatter
    if args.fix_cdom is not None:
        fix["cdom"] = args.fix_cdom
    setup = setup_kwargs(args)
    aux = _auxiliary(args, sigma)
    err.write(camera_note(args.camera, setup["wavelengths"]))
    try:
        res = estimate(M, depth=args.depth, distance=args.distance, sigma=sigma,
                       saturation=args.saturation, mode=args.mode or "lm",
                       fix=fix or None, max_iter=args.max_iter, gain=args.gain,
                       uncertain=uncertain_from_args(args), auxiliary=aux or None, **setup)
    except ValueError as exc:
        msg = str(exc)
        what = getattr(exc, "argument", None)
        if what in ("rgb", "sigma"):
            why = exc.reason
            if "expected" in why and "shape" in why:  # in the file's orientation
                raise InputError("measurements", f"{args.measurements}: one row per patch and one "
                                 f"column per channel expected; {msg} (channels x patches)"
                                 ) from None
            raise InputError("measurements", f"{args.measurements}: "
                             f"{'the _sd columns: ' if what == 'sigma' else ''}{why}") from None
        raise
    if args.attenuation:
        with atomic_open(args.attenuation, "--attenuation") as fh:
            w = safe_writer(fh, lineterminator="\n")
            w.writerow(["wavelength_nm", "attenuation_k"])
            w.writerows([f"{wl:g}", repr(float(k))] for wl, k in zip(res.wavelengths,
                                                                     res.attenuation))
        err.write(f"wrote {args.attenuation}\n")
    if args.spectrum:
        with atomic_open(args.spectrum, "--spectrum") as fh:
            w = safe_writer(fh, lineterminator="\n")
            w.writerow(_spectrum_header(res.wavelengths, batch=False))
            w.writerows(_spectrum_rows(res.beam_attenuation, res.beam_attenuation_ci,
                                       res.attenuation, res.wavelengths))
        err.write(f"wrote {args.spectrum}\n")
    if args.json:
        from measure.statements import statements

        out.write(json_text(res.to_dict() | {"statements": statements(res, "chart", aux)}))
    else:
        out.write(_summary(res, args.gain, aux))
    return EXIT_OK if res.reliable else EXIT_NOT_RELIABLE
