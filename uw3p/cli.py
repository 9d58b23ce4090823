"""The ``uw3p`` command: simulate a chart, estimate the water, regenerate figures, benchmark.

    uw3p simulate --chl 1 --cdom 0.1 --depth 10 --distance 5 [--out sim.json|m.csv]
    uw3p estimate m.csv --depth 10 --distance 5 [--json] [--mode paper] [--saturation S] [--gain free]
    uw3p estimate --batch charts.csv --distance 5 [--json]
    uw3p design --depth 15 --distance 1 --chl 1 --cdom 0.1 [--lux 20000] [--camera ...]
    uw3p calibrate AIR.dng --corners "x1,y1 x2,y2 x3,y3 x4,y4" --out profile.json
    uw3p measure UW.dng --profile profile.json --depth 5 --distance 1.5 --corners "..." --out DIR
    uw3p figures [--grid reduced] [--out figures]      (what `make reproduce-figures` runs)
    uw3p bench [--quick]                               (what `make bench` runs)
    uw3p --version

Exit status: 0 success (``estimate``, ``measure``: every estimate is reliable; ``calibrate``: the
profile fits; ``design``: C measurable to ±30 % at 95 %), 1 an estimate is not reliable or did not converge (its flags say why; ``design``:
C not measurable to ±30 %), 2 bad input (the message names the argument
or file), 130 interrupted. ``estimate`` needs the noise (``red_sd,green_sd,blue_sd`` columns, as
``simulate`` writes them) to call an estimate reliable.
Output cut short by its reader (``uw3p estimate ... | head``) ends quietly with the status the
command would have had.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from . import __version__
from .patchfile import patch_csv, read_batch_csv, read_patch_csv

EXIT_OK, EXIT_NOT_RELIABLE, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


# --------------------------------------------------------------------------- shared options
def _add_setup(p):
    p.add_argument("--camera", default="Nikon 5100 (NPL)",
                   help="colour-science camera name or CSV file (default: %(default)s)")
    p.add_argument("--illuminant", default=None, help="colour-science illuminant name or CSV (default D65)")
    p.add_argument("--reflectances", default=None, help="chart name or CSV (default BabelColor Average)")
    p.add_argument("--step", type=float, default=None, help="wavelength step in nm (default 10)")
    p.add_argument("--wl-min", type=float, default=400.0, help="first wavelength, nm (default 400)")
    p.add_argument("--wl-max", type=float, default=700.0, help="last wavelength, nm (default 700)")
    _add_water(p)


def _add_water(p):
    g = p.add_argument_group("water model (forward.Water; defaults: the paper's)")
    g.add_argument("--path-model", default="beam", choices=["beam", "absorption"],
                   help="k = exp(-L c) (beam, default) or exp(-L a) (eq 13 as printed)")
    g.add_argument("--cdom-slope", type=float, default=None, help="eq 6 slope, nm^-1 (0.014)")
    g.add_argument("--nap-slope", type=float, default=None, help="eq 7 slope, nm^-1 (0.011)")
    g.add_argument("--b-k", type=float, default=None, help="Table 1 b_k at 470 nm, m^-1 (0.00068)")


def _grid(args):
    if args.step is None and args.wl_min == 400.0 and args.wl_max == 700.0:
        return None
    step = 10.0 if args.step is None else args.step
    if not step > 0:
        raise ValueError(f"--step: must be > 0, got {step}")
    return np.arange(args.wl_min, args.wl_max + step / 2, step)


def _water(args):
    import forward

    kw = {"path_model": args.path_model}
    for opt, key in (("cdom_slope", "cdom_slope"), ("nap_slope", "nap_slope"), ("b_k", "b_k")):
        if getattr(args, opt) is not None:
            kw[key] = getattr(args, opt)
    try:
        return forward.Water(**kw)
    except ValueError as exc:
        raise ValueError(f"--{str(exc).replace('_', '-')}") from None


def _write_file(path, text, err):
    p = Path(path)
    try:
        p.write_text(text, encoding="utf-8")
    except OSError as exc:
        why = "its folder does not exist" if not p.parent.is_dir() else exc.strerror
        raise ValueError(f"--out: cannot write {p}: {why}") from None
    err.write(f"wrote {p}\n")


# --------------------------------------------------------------------------- simulate
def _simulate(args, out, err):
    import forward

    if args.out is not None and not args.out.lower().endswith((".json", ".csv")):
        raise ValueError(f"--out: must end in .json or .csv, got {args.out!r}")
    sim = forward.simulate_chart(args.chl, args.cdom, args.depth, args.distance, camera=args.camera,
                                 illuminant=args.illuminant, reflectances=args.reflectances,
                                 noise=not args.no_noise, seed=args.seed, wavelengths=_grid(args),
                                 water=_water(args))
    if args.out is None:
        out.write(patch_csv(sim.rgb, sim.rgb_sigma))
    else:
        _write_file(args.out, sim.to_json() if args.out.lower().endswith(".json")
                    else patch_csv(sim.rgb, sim.rgb_sigma), err)
    return EXIT_OK


# --------------------------------------------------------------------------- estimate
def _setup_kwargs(args):
    return dict(camera=args.camera, illuminant=args.illuminant, reflectances=args.reflectances,
                wavelengths=_grid(args), water=_water(args))


def _ci(ci):
    return [float(ci[0]), float(ci[1])]


def _json(obj) -> str:
    """Strict JSON: an open interval end (inf) is written "inf", an untested value (NaN) null."""
    from measure.output import strict_json

    return json.dumps(strict_json(obj), indent=1, allow_nan=False) + "\n"


def _estimate_batch(args, out, err):
    from sca import estimate_batch

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
                         fix=fix, max_iter=args.max_iter, gain=args.gain, **_setup_kwargs(args))
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
        out.write(_json(dict(wavelengths=res.wavelengths.tolist(), noise_known=res.noise_known,
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


def _interval_text(ci, unit):
    hi = "inf" if not np.isfinite(ci[1]) else f"{ci[1]:.4g}"
    return f"95 % interval [{ci[0]:.4g}, {hi}] {unit}"


def _estimate(args, out, err):
    from sca import estimate

    if (args.batch is None) == (args.measurements is None):
        raise ValueError("measurements: give either a measurements CSV or --batch FILE")
    if args.batch is not None:
        return _estimate_batch(args, out, err)
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
                       **_setup_kwargs(args))
    except ValueError as exc:
        msg = str(exc)
        if msg.startswith(("rgb:", "sigma:")):  # name the file, in its orientation (rows = patches)
            raise ValueError(f"measurements: {args.measurements}: one row per patch and one column "
                             f"per channel expected; {msg} (channels x patches)") from None
        raise
    if args.json:
        out.write(_json(res.to_dict()))
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
        out.write(f"reliable         {res.reliable}" + (f" (flags: {', '.join(res.flags)})"
                                                       if res.flags else "") + "\n")
        out.write(f"converged        {res.converged} ({res.status}; {res.iterations} iterations, "
                  f"mode {res.mode}, path model {res.path_model})\n")
        out.write("wavelength_nm,attenuation_k\n")
        for wl, k in zip(res.wavelengths, res.attenuation):
            out.write(f"{wl:g},{k:.8g}\n")
    return EXIT_OK if res.reliable else EXIT_NOT_RELIABLE


# --------------------------------------------------------------------------- photographs
def _add_photo(p):
    p.add_argument("--camera", default="Nikon 5100 (NPL)",
                   help="colour-science camera name or CSV (wavelength,red,green,blue)")
    p.add_argument("--quantal", action="store_true",
                   help="the camera curves act on photons (quantum efficiency): convert to energy")
    p.add_argument("--corners", required=True,
                   help='the chart\'s outer corners in pixels, "x1,y1 x2,y2 x3,y3 x4,y4": next to '
                        "patch 1 (dark skin), patch 6 (bluish green), patch 24 (black), patch 19 "
                        "(white)")
    p.add_argument("--layout", default="patches", choices=["patches", "card"],
                   help="the corners are those of the patch grid (default) or of the whole card")
    p.add_argument("--illuminant", default=None, help="surface illuminant name or CSV (default D65)")
    p.add_argument("--black-level", type=float, default=None, help="override the file's, raw units")
    p.add_argument("--white-level", type=float, default=None, help="override the file's, raw units")


def _read_photo(args, image):
    import measure

    return measure.read_image(image, black_level=args.black_level, white_level=args.white_level)


def _calibrate(args, out, err):
    import measure

    photo = _read_photo(args, args.image)
    cands = measure.orientations(photo, args.corners, measure.LAYOUTS[args.layout])
    c, _, ok = cands["as given"]
    if not ok:
        passing = [k for k, v in cands.items() if v[2]]
        hint = f" (it does {passing[0]})" if len(passing) == 1 else ""
        raise ValueError("corners: the grey row (patches 19-24) does not fall from white to black "
                         f"in the order given{hint}; give the corners next to patch 1, 6, 24, 19")
    sample = measure.sample_patches(photo, c, measure.LAYOUTS[args.layout])
    prof = measure.calibrate(sample, camera=args.camera, quantal=args.quantal,
                             illuminant=args.illuminant, image=photo.path)
    _write_file(args.out, prof.to_json(), err)
    out.write(f"channel gains (largest 1): " + ", ".join(f"{g:.4g}" for g in prof.gains)
              + "\nchi2/dof per channel: " + ", ".join(f"{v:.3g}" for v in prof.chi2_dof)
              + "\nfit_rms per channel: " + ", ".join(f"{v:.3g}" for v in prof.fit_rms)
              + f"\nreliable: {prof.reliable}" + (f" (flags: {', '.join(prof.flags)})"
                                                  if prof.flags else "") + "\n")
    return EXIT_OK if prof.reliable else EXIT_NOT_RELIABLE


def _measure_one(args, image, outdir):
    """Measure one image into ``outdir``; returns (exit code, summary row)."""
    import measure

    meas = measure.measure(_read_photo(args, image), corners=args.corners, depth=args.depth,
                           distance=args.distance, camera=args.camera, quantal=args.quantal,
                           profile=args.profile, illuminant=args.illuminant,
                           layout=args.layout, water=_water(args))
    measure.write_outputs(meas, outdir, version=__version__)
    e = meas.estimate
    row = dict(image=str(image), chl=e.chl, chl_lo=e.chl_ci[0], chl_hi=e.chl_ci[1], cdom=e.cdom,
               cdom_lo=e.cdom_ci[0], cdom_hi=e.cdom_ci[1], gain=e.gain, fit_rms=e.fit_rms,
               chi2_dof=e.chi2_dof, orientation=meas.orientation, reliable=meas.reliable,
               flags=" ".join(meas.flags), out=str(outdir), error="")
    return (EXIT_OK if meas.reliable else EXIT_NOT_RELIABLE), row


def _measure_worker(job):
    args, image, outdir = job
    try:
        return _measure_one(args, image, outdir)
    except ValueError as exc:
        return EXIT_BAD_INPUT, dict(image=str(image), error=str(exc), out=str(outdir))


SUMMARY_COLUMNS = ("image", "chl", "chl_lo", "chl_hi", "cdom", "cdom_lo", "cdom_hi", "gain",
                   "fit_rms", "chi2_dof", "orientation", "reliable", "flags", "out", "error")


def _measure(args, out, err):
    if args.depth is None or args.distance is None:
        raise ValueError("--depth, --distance: both are required")
    src = Path(args.image)
    if src.is_dir():
        return _measure_folder(args, src, out, err)
    code, row = _measure_one(args, src, Path(args.out))
    e = row
    out.write(f"chl (C)          {e['chl']:.6g} mg m^-3, 95 % interval [{e['chl_lo']:.4g}, "
              f"{e['chl_hi']:.4g}]\n"
              f"cdom a_CDOM(440) {e['cdom']:.6g} m^-1, 95 % interval [{e['cdom_lo']:.4g}, "
              f"{e['cdom_hi']:.4g}]\n"
              f"gain             {e['gain']:.6g} raw units per model unit\n"
              f"fit              fit_rms {e['fit_rms']:.3g}, chi2/dof {e['chi2_dof']:.3g}\n"
              f"orientation      {e['orientation']}\n"
              f"reliable         {e['reliable']}" + (f" (flags: {e['flags']})" if e["flags"] else "")
              + f"\nwrote            {args.out}/measurement.json, corrected.tiff, corrected.png, "
                "report.png\n")
    return code


def _measure_folder(args, src, out, err):
    """Every image of a folder (a dive's photos): one output folder each, summary.csv, a
    progress bar, all cores. Files that are not images are listed in the summary with their
    error."""
    import csv
    from concurrent.futures import ProcessPoolExecutor

    from tqdm import tqdm

    from measure.image import RAW_EXTENSIONS, TIFF_EXTENSIONS

    files = sorted(p for p in src.iterdir() if p.is_file() and not p.name.startswith(".")
                   and p.suffix.lower() in RAW_EXTENSIONS + TIFF_EXTENSIONS)
    if not files:
        raise ValueError(f"image: folder {src} has no RAW or TIFF files "
                         f"({', '.join(RAW_EXTENSIONS + TIFF_EXTENSIONS)})")
    root = Path(args.out)
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out: cannot create {root}: {exc.strerror}") from None
    jobs = [(args, f, root / f.stem) for f in files]
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    with ProcessPoolExecutor(workers) as pool:
        results = list(tqdm(pool.map(_measure_worker, jobs), total=len(jobs), file=err,
                            desc="measuring", unit="image"))
    with open(root / "summary.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=SUMMARY_COLUMNS)
        w.writeheader()
        for _, row in results:
            w.writerow({k: row.get(k, "") for k in SUMMARY_COLUMNS})
    codes = [c for c, _ in results]
    n_ok = codes.count(EXIT_OK)
    out.write(f"{len(files)} files: {n_ok} reliable, {codes.count(EXIT_NOT_RELIABLE)} not "
              f"reliable, {codes.count(EXIT_BAD_INPUT)} not measurable; {root}/summary.csv\n")
    return max(codes)


# --------------------------------------------------------------------------- design
#: A measurement is "reliable" to the design tool when the 95 % half-width of C is at most
#: this fraction of C, and "coarse" up to COARSE.
DESIGN_GOOD, DESIGN_COARSE = 0.30, 1.00


def _pm(rel):
    return "not bounded" if not np.isfinite(rel) else f"±{100 * rel:.0f} %"


def _design(args, out, err):
    import forward
    from sca import precision

    sensor = forward.SensorSettings(illuminance_lux=args.lux, exposure_mode=args.exposure)
    kw = dict(camera=args.camera, illuminant=args.illuminant, reflectances=args.reflectances,
              wavelengths=_grid(args), water=_water(args), sensor=sensor)
    cond = (args.chl, args.cdom, args.depth, args.distance)
    p = precision(*cond, gain=args.gain, **kw)
    fixed = precision(*cond, gain=args.gain, fix={"cdom"}, **kw)
    known = precision(*cond, gain="known", **kw) if args.gain != "known" else p
    rel, rel_fix = float(p.chl_rel95[0]), float(fixed.chl_rel95[0])
    gains = {"known": "exposure known (data in model units)",
             "free": "exposure unknown, camera's channel balance calibrated",
             "channels": "exposure and channel balance unknown (uncalibrated camera)"}
    lines = [f"camera {args.camera}, {args.lux:g} lx at the surface, chart at {args.depth:g} m "
             f"seen from {args.distance:g} m; C = {args.chl:g} mg m^-3, a_CDOM(440) = "
             f"{args.cdom:g} m^-1; {gains[args.gain]}",
             f"C                {_pm(rel)} (95 %; sd {p.chl_sd[0]:.3g} mg m^-3)",
             f"a_CDOM(440)      {_pm(float(p.cdom_rel95[0]))} (95 %; sd {p.cdom_sd[0]:.3g} m^-1)",
             f"attenuation k    expected RRMSE (eq 19) {p.rrmse[0]:.2g}"]
    corr = float(p.correlation[0])
    if abs(corr) > 0.95:
        lines.append(f"C and a_CDOM are hard to separate here (correlation {corr:+.2f}): the "
                     "chart fixes a combination of them better than either.")
    lines.append(f"with a_CDOM measured separately, C to {_pm(rel_fix)}")
    if args.gain != "known":
        lines.append(f"with the exposure known, C to {_pm(float(known.chl_rel95[0]))}")
    if p.flags[0]:
        lines.append("caveats: " + ", ".join(p.flags[0]) + " (the bound may not be attained)")
    at = f"at {args.depth:g} m with this camera"
    if rel <= DESIGN_GOOD:
        verdict = f"{at}, C is measurable to {_pm(rel)}: a reliable measurement is possible."
    elif rel_fix <= DESIGN_GOOD:
        verdict = (f"{at}, C is measurable to {_pm(rel)}; fix a_CDOM (measure it separately) to "
                   f"reach {_pm(rel_fix)}.")
    elif rel <= DESIGN_COARSE:
        verdict = (f"{at}, C is measurable only coarsely ({_pm(rel)}); move closer, shoot "
                   "shallower or in brighter light.")
    else:
        verdict = f"{at}, C cannot be measured ({_pm(rel)}): the chart does not constrain it."
    lines.append("verdict          " + verdict)
    out.write("\n".join(lines) + "\n")
    return EXIT_OK if rel <= DESIGN_GOOD else EXIT_NOT_RELIABLE


# --------------------------------------------------------------------------- figures, bench
def _figures(args, out, err):
    from experiments.__main__ import main as figures_main

    argv = list(args.names) + ["--out", args.out]
    for opt in ("grid", "cache", "workers", "setting", "report"):
        if getattr(args, opt) is not None:
            argv += [f"--{opt}", str(getattr(args, opt))]
    figures_main(argv)
    return EXIT_OK


def _bench(args, out, err):
    # one BLAS thread (see the Makefile and DECISIONS.md); set before numpy is imported, so the
    # benchmark runs in its own process
    env = dict(os.environ)
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    cmd = [sys.executable, "-m", "experiments.benchmark"] + (["--quick"] if args.quick else [])
    proc = subprocess.Popen(cmd, env=env)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        proc.wait()
        raise


# --------------------------------------------------------------------------- parser, main
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="uw3p", description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[2:]))
    parser.add_argument("--version", action="version", version=f"uw3p {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="simulate the 24 patch values of a chart underwater")
    p.add_argument("--chl", type=float, required=True, help="chlorophyll C, mg m^-3")
    p.add_argument("--cdom", type=float, required=True, help="a_CDOM(440), m^-1")
    p.add_argument("--depth", type=float, required=True, help="chart depth, m")
    p.add_argument("--distance", type=float, required=True, help="camera-to-chart distance, m")
    p.add_argument("--no-noise", action="store_true", help="the exact expectation, no sensor noise")
    p.add_argument("--seed", type=int, default=None, help="noise seed")
    p.add_argument("--out", default=None, help="output file (.json: everything; .csv: patch values)")
    _add_setup(p)
    p.set_defaults(func=_simulate)

    p = sub.add_parser("calibrate", help="fit a camera's channel balance from a photo of the "
                                         "chart in air")
    p.add_argument("image", help="RAW (any LibRaw format) or linear 16-bit TIFF of the chart in air")
    p.add_argument("--out", required=True, help="the profile to write (JSON)")
    _add_photo(p)
    p.set_defaults(func=_calibrate)

    p = sub.add_parser("measure", help="measure the water from a photo of the chart underwater "
                                       "and colour-correct it")
    p.add_argument("image", help="RAW or linear 16-bit TIFF, or a folder of them (a dive)")
    p.add_argument("--depth", type=float, default=None, help="chart depth, m")
    p.add_argument("--distance", type=float, default=None, help="camera-to-chart distance, m")
    p.add_argument("--profile", default=None, help="camera profile from uw3p calibrate")
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    _add_photo(p)
    _add_water(p)
    p.set_defaults(func=_measure)

    p = sub.add_parser("estimate", help="estimate C, CDOM and attenuation from patch values")
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
    _add_setup(p)
    p.set_defaults(func=_estimate)

    p = sub.add_parser("design", help="how precisely can this camera measure C and CDOM here? "
                                      "(the Cramer-Rao bound, sca.precision)")
    p.add_argument("--chl", type=float, required=True, help="expected chlorophyll C, mg m^-3")
    p.add_argument("--cdom", type=float, required=True, help="expected a_CDOM(440), m^-1")
    p.add_argument("--depth", type=float, required=True, help="chart depth, m")
    p.add_argument("--distance", type=float, required=True, help="camera-to-chart distance, m")
    p.add_argument("--lux", type=float, default=20000.0, help="surface illuminance, lx (default 20000)")
    p.add_argument("--exposure", default="capped", choices=["capped", "iset"],
                   help="auto-exposure model (default capped at 1/30 s)")
    p.add_argument("--gain", default="free", choices=["known", "free", "channels"],
                   help="exposure known, unknown (default: a photograph), or unknown per channel "
                        "(uncalibrated camera)")
    _add_setup(p)
    p.set_defaults(func=_design)

    p = sub.add_parser("figures", help="regenerate Figs 5-13 and the noise study (make reproduce-figures)")
    p.add_argument("names", nargs="*", help="a subset of the figure scripts (default all)")
    p.add_argument("--out", default="figures", help="output folder (default figures/)")
    p.add_argument("--grid", default=None, choices=["paper", "reduced"], help="sweep grid (default paper)")
    p.add_argument("--cache", default=None, help="result cache folder (default cache/)")
    p.add_argument("--workers", type=int, default=None, help="processes (default 2)")
    p.add_argument("--setting", default=None, choices=["default", "paper-like"],
                   help="one sensor setting (default: both, into OUT/<setting>/)")
    p.add_argument("--report", default=None, metavar="FILE",
                   help="rewrite the generated tables of FILE (REPRODUCTION.md)")
    p.set_defaults(func=_figures)

    p = sub.add_parser("bench", help="speed against error of every estimator (make bench)")
    p.add_argument("--quick", action="store_true", help="reduced sizes (a check, not the record)")
    p.set_defaults(func=_bench)
    return parser


def _emit(text, out, code):
    """Write the buffered output; a reader that closed the pipe ends it quietly."""
    try:
        out.write(text)
        out.flush()
    except BrokenPipeError:
        if out is sys.stdout:  # no second error when Python flushes stdout at exit
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
    return code


def main(argv=None, out=None, err=None) -> int:
    out = sys.stdout if out is None else out
    err = sys.stderr if err is None else err
    args = build_parser().parse_args(argv)  # usage errors: argparse prints them and exits 2
    buf = io.StringIO() if args.command in ("simulate", "estimate", "design", "calibrate",
                                            "measure") else out
    try:
        code = int(args.func(args, buf, err) or 0)
    except ValueError as exc:
        err.write(f"uw3p {args.command}: error: {exc}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        err.write(f"uw3p {args.command}: interrupted\n")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return _emit("", out, EXIT_OK)
    return _emit(buf.getvalue(), out, code) if buf is not out else code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
