"""``uw3p estimate``: the water (C, CDOM, attenuation) from a chart's 24 patch values.

    uw3p estimate m.csv --depth 10 --distance 5 [--json] [--mode paper] [--saturation S]
                  [--gain free] [--fix-backscatter S] [--fix-cdom A]
    uw3p estimate --batch charts.csv [--depth D] [--distance R] [--json]

One chart is fitted by ``sca.estimate``, a batch (``--batch``) by ``sca.estimate_batch``.
Exit status 0 when every estimate is reliable, 1 when one is not (its flags say why).
"""

from __future__ import annotations

import math

from .common import (EXIT_NOT_RELIABLE, EXIT_OK, add_budget_options, add_setup_options,
                     budget_text, json_text, uncertain_from_args,
                     setup_kwargs)

__all__ = ["NAME", "BUFFERED", "add_parser", "run"]

#: The subcommand's name.
NAME = "estimate"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True


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
                   help="CSV with a header patch,red,green,blue[,red_sd,green_sd,blue_sd] "
                        "(one row per patch)")
    p.add_argument("--batch", default=None, metavar="FILE",
                   help="many charts at once (sca.estimate_batch): CSV with columns chart, patch, "
                        "red, green, blue [, depth_m, distance_m]; one output row per chart")
    p.add_argument("--depth", type=float, default=None, help="chart depth, m")
    p.add_argument("--distance", type=float, default=None, help="camera-to-chart distance, m")
    p.add_argument("--mode", default=None, choices=["safeguarded", "paper"],
                   help="single chart only (default safeguarded)")
    p.add_argument("--max-iter", type=int, default=100)
    p.add_argument("--fix-backscatter", type=float, default=None, help="hold s fixed (e.g. 0)")
    p.add_argument("--fix-cdom", type=float, default=None, help="hold a_CDOM(440) fixed, m^-1")
    p.add_argument("--saturation", type=float, default=None,
                   help="the sensor's clip level in the data's units (values there are flagged)")
    p.add_argument("--json", action="store_true", help="print the whole result as JSON")
    p.add_argument("--gain", default="known", choices=["known", "free"],
                   help="known: values in model units (as simulate writes them); free: any units "
                        "(e.g. raw camera values), one unknown exposure gain fitted with the water")
    add_setup_options(p)
    add_budget_options(p)
    p.set_defaults(func=run)
    return p


def _ci(ci):
    return [float(ci[0]), float(ci[1])]


def _interval_text(ci, unit):
    hi = "inf" if not math.isfinite(ci[1]) else f"{ci[1]:.4g}"
    return f"95 % interval [{ci[0]:.4g}, {hi}] {unit}"


def _run_batch(args, out, err):
    import numpy as np

    from sca import estimate_batch

    from .patchfile import read_batch_csv

    if args.mode is not None:
        raise ValueError("--mode: the batched solver (--batch) has one algorithm (variable "
                         "projection + Levenberg-Marquardt); omit --mode")
    if args.fix_cdom is not None:
        raise ValueError("--fix-cdom: not available with --batch")
    charts, M, sigma, depth, distance = read_batch_csv(args.batch)
    for name, arr, opt in (("depth", depth, args.depth), ("distance", distance, args.distance)):
        if np.isnan(arr).any():
            if opt is None:
                raise ValueError(f"--{name}: required unless the batch file has a {name}_m column")
            arr[np.isnan(arr)] = opt
    fix = {"backscatter": args.fix_backscatter} if args.fix_backscatter is not None else None
    res = estimate_batch(M, depth=depth, distance=distance, sigma=sigma, saturation=args.saturation,
                         fix=fix, max_iter=args.max_iter, gain=args.gain,
                         uncertain=uncertain_from_args(args), **setup_kwargs(args))
    if args.json:
        records = [dict(chart=c, chl=float(res.chl[j]), cdom=float(res.cdom[j]),
                        chl_ci=_ci(res.chl_ci[j]), cdom_ci=_ci(res.cdom_ci[j]),
                        reliable=bool(res.reliable[j]), flags=list(res.flags[j]),
                        fit_rms=float(res.fit_rms[j]), chi2_dof=float(res.chi2_dof[j]),
                        chi2_p=float(res.chi2_p[j]), dof=int(res.dof[j]),
                        backscatter=res.backscatter[j].tolist(), gain=float(res.gain[j]),
                        gain_ci=_ci(res.gain_ci[j]), attenuation=res.attenuation[j].tolist(),
                        objective=float(res.objective[j]), converged=bool(res.converged[j]),
                        iterations=int(res.iterations[j]), status=str(res.status[j]),
                        depth=float(depth[j]), distance=float(distance[j]))
                   for j, c in enumerate(charts)]
        out.write(json_text(dict(wavelengths=res.wavelengths.tolist(), noise_known=res.noise_known,
                                 charts=records)))
    else:
        m = M.shape[1]
        out.write("chart,chl,chl_lo,chl_hi,cdom,cdom_lo,cdom_hi,reliable,flags,fit_rms,chi2_dof,"
                  + ",".join(f"backscatter_{j}" for j in range(m))
                  + ",gain,gain_lo,gain_hi,objective,converged,iterations,status\n")
        for j, c in enumerate(charts):
            out.write(f"{c},{res.chl[j]!r},{res.chl_ci[j, 0]!r},{res.chl_ci[j, 1]!r},"
                      f"{res.cdom[j]!r},{res.cdom_ci[j, 0]!r},{res.cdom_ci[j, 1]!r},"
                      f"{bool(res.reliable[j])},{' '.join(res.flags[j])},{res.fit_rms[j]!r},"
                      f"{res.chi2_dof[j]!r},"
                      + ",".join(repr(float(v)) for v in res.backscatter[j])
                      + f",{res.gain[j]!r},{res.gain_ci[j, 0]!r},{res.gain_ci[j, 1]!r}"
                      + f",{res.objective[j]!r},{bool(res.converged[j])},{res.iterations[j]},"
                        f"{res.status[j]}\n")
    err.write(f"{len(charts)} charts, {int(res.converged.sum())} converged, "
              f"{int(res.reliable.sum())} reliable, {res.elapsed_s:.3f} s\n")
    return EXIT_OK if res.reliable.all() else EXIT_NOT_RELIABLE


def run(args, out, err) -> int:
    """Estimate the water of one chart (``measurements``) or of a batch (``--batch``).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``measurements`` or ``batch`` (CSV files), ``depth`` (m), ``distance``
        (m), ``mode``, ``max_iter``, ``fix_backscatter``, ``fix_cdom`` (m^-1), ``saturation``
        (data units), ``json``, ``gain`` and the setup options.
    out : text stream
        The estimate: a text summary and k(lambda) as CSV, one CSV row per chart for a batch,
        or JSON with ``--json``.
    err : text stream
        For a batch, a one-line count of converged and reliable charts.

    Returns
    -------
    int
        ``EXIT_OK`` when every estimate is reliable, else ``EXIT_NOT_RELIABLE``.

    Raises
    ------
    ValueError
        Bad input; the message names the argument or file.
    """
    from sca import estimate

    from .patchfile import read_patch_csv

    if (args.batch is None) == (args.measurements is None):
        raise ValueError("measurements: give either a measurements CSV or --batch FILE")
    if args.batch is not None:
        return _run_batch(args, out, err)
    if args.depth is None or args.distance is None:
        raise ValueError("--depth, --distance: both are required")
    M, sigma = read_patch_csv(args.measurements)
    fix = {}
    if args.fix_backscatter is not None:
        fix["backscatter"] = args.fix_backscatter
    if args.fix_cdom is not None:
        fix["cdom"] = args.fix_cdom
    try:
        res = estimate(M, depth=args.depth, distance=args.distance, sigma=sigma,
                       saturation=args.saturation, mode=args.mode or "safeguarded",
                       fix=fix or None, max_iter=args.max_iter, gain=args.gain,
                       uncertain=uncertain_from_args(args), **setup_kwargs(args))
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith(("rgb:", "sigma:")):  # name the file, in its orientation (rows = patches)
            raise ValueError(f"measurements: {args.measurements}: one row per patch and one column "
                             f"per channel expected; {msg} (channels x patches)") from None
        raise
    if args.json:
        out.write(json_text(res.to_dict()))
    else:
        out.write(f"chl (C)          {res.chl:.6g} mg m^-3, {_interval_text(res.chl_ci, 'mg m^-3')}\n")
        out.write(f"cdom a_CDOM(440) {res.cdom:.6g} m^-1, {_interval_text(res.cdom_ci, 'm^-1')}\n")
        out.write("backscatter s    " + " ".join(f"{v:.6g}" for v in res.backscatter) + "\n")
        if args.gain == "free":
            out.write(f"gain             {res.gain:.6g}, {_interval_text(res.gain_ci, '')}"
                      "(data units per model unit)\n")
        chi2 = (f"chi2/dof {res.chi2_dof:.3g} (p = {res.chi2_p:.3g}, dof {res.dof})"
                if res.noise_known else "chi2 not tested: the noise is unknown")
        out.write(f"fit              fit_rms {res.fit_rms:.3g}, {chi2}\n")
        if res.budget:
            out.write(f"budget of C      sd {res.budget['chl']['sd']:.3g} mg m^-3: "
                      f"{budget_text(res.budget, 'chl')}\n" if "chl" in res.budget else "")
            out.write(f"budget of CDOM   sd {res.budget['cdom']['sd']:.3g} m^-1: "
                      f"{budget_text(res.budget, 'cdom')}\n" if "cdom" in res.budget else "")
        elif res.noise_known:
            out.write("budget           none: the paper's exact model (--exact)\n")
        out.write(f"reliable         {res.reliable}" + (f" (flags: {', '.join(res.flags)})"
                                                       if res.flags else "") + "\n")
        out.write(f"converged        {res.converged} ({res.status}; {res.iterations} iterations, "
                  f"mode {res.mode}, path model {res.path_model})\n")
        out.write("wavelength_nm,attenuation_k\n")
        for wl, k in zip(res.wavelengths, res.attenuation):
            out.write(f"{wl:g},{k:.8g}\n")
    return EXIT_OK if res.reliable else EXIT_NOT_RELIABLE
