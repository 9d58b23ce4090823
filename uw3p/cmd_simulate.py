"""``uw3p simulate``: the 24 patch values a camera records of a chart underwater.

    uw3p simulate --chl 1 --cdom 0.1 --depth 10 --distance 5 [--no-noise] [--seed N]
                  [--out sim.json|m.csv]

Without ``--out`` the patch values and their standard deviations are printed as CSV (the
format ``uw3p estimate`` reads).
"""

from __future__ import annotations

from forward.errors import InputError

from .common import (EXIT_OK, add_setup_options, camera_note, check_spectra_args,
                     water_from_args, wavelengths_from_args, write_file)

__all__ = ["NAME", "BUFFERED", "add_parser", "run"]

#: The subcommand's name.
NAME = "simulate"
#: Output is collected and written when the command ends (see ``uw3p.cli.main``).
BUFFERED = True


def add_parser(sub):
    """Register ``simulate`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="simulate the 24 patch values of a chart underwater")
    p.add_argument("--chl", type=float, required=True, help="chlorophyll C, mg m^-3")
    p.add_argument("--cdom", type=float, required=True, help="a_CDOM(440), m^-1")
    p.add_argument("--depth", type=float, required=True, help="chart depth, m")
    p.add_argument("--distance", type=float, required=True, help="camera-to-chart distance, m")
    p.add_argument("--no-noise", action="store_true", help="the exact expectation, no sensor noise")
    p.add_argument("--seed", type=int, default=None, help="noise seed")
    p.add_argument("--out", default=None, help="output file (.json: everything; .csv: patch values)")
    add_setup_options(p)
    p.set_defaults(func=run)
    return p


def run(args, out, err) -> int:
    """Simulate the chart and write it to ``--out`` or ``out``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``chl`` (mg m^-3), ``cdom`` (a_CDOM(440), m^-1), ``depth`` (m),
        ``distance`` (m), ``no_noise``, ``seed``, ``out`` and the setup options.
    out : text stream
        Patch CSV when ``--out`` is not given.
    err : text stream
        ``wrote <file>`` when it is; a note when the camera's curves stop inside the grid.

    Returns
    -------
    int
        ``EXIT_OK``.

    Raises
    ------
    ValueError
        Bad input (an ``--out`` not ending in .json or .csv, a value the model refuses); the
        message names the option.
    """
    import forward

    from .patchfile import patch_csv

    if args.out is not None and not args.out.lower().endswith((".json", ".csv")):
        raise InputError("--out", f"must end in .json or .csv, got {args.out!r}")
    check_spectra_args(args)
    err.write(camera_note(args.camera, wavelengths_from_args(args)))
    sim = forward.simulate_chart(args.chl, args.cdom, args.depth, args.distance, camera=args.camera,
                                 illuminant=args.illuminant, reflectances=args.reflectances,
                                 noise=not args.no_noise, seed=args.seed,
                                 wavelengths=wavelengths_from_args(args),
                                 water=water_from_args(args))
    if args.out is None:
        out.write(patch_csv(sim.rgb, sim.rgb_sigma))
    else:
        write_file(args.out, sim.to_json() if args.out.lower().endswith(".json")
                   else patch_csv(sim.rgb, sim.rgb_sigma), err)
    return EXIT_OK
