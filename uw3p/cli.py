"""The ``uw3p`` command: simulate a chart, estimate the water, regenerate figures, benchmark.

    uw3p simulate --chl 1 --cdom 0.1 --depth 10 --distance 5 [--out sim.json|m.csv]
    uw3p estimate m.csv --depth 10 --distance 5 [--json] [--attenuation k.csv] [--gain free]
    uw3p estimate --batch charts.csv --distance 5 [--json] [--attenuation k.csv]
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
command would have had. Patch CSV files are read by column name (patch, red/R, green/G,
blue/B, red_sd/R_sd, ...; a batch adds chart, depth_m, distance_m), in UTF-8 with or without a
byte-order mark, with comma, semicolon or tab separators and a decimal comma where the
separator is not a comma (the README's command-line section).
"""

from __future__ import annotations

import argparse
import io
import shlex
import os
import sys

from . import (__version__, cmd_bench, cmd_calibrate, cmd_design, cmd_estimate, cmd_figures,
               cmd_measure, cmd_simulate)
from .common import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_OK, option_message, plain

__all__ = ["COMMANDS", "build_parser", "main"]

#: The subcommand modules, in the order ``uw3p --help`` lists them. Each has ``NAME``,
#: ``BUFFERED`` (output collected and written at the end), ``add_parser(sub)`` and
#: ``run(args, out, err) -> exit status``; a new subcommand is a new module added here.
COMMANDS = (cmd_simulate, cmd_calibrate, cmd_measure, cmd_estimate, cmd_design, cmd_figures,
            cmd_bench)


def build_parser() -> argparse.ArgumentParser:
    """The ``uw3p`` argument parser with every subcommand of :data:`COMMANDS`.

    Returns
    -------
    argparse.ArgumentParser
        Parsing sets ``command`` (the subcommand's name) and ``func`` (its ``run``).
    """
    doc = plain(__doc__)
    parser = argparse.ArgumentParser(prog="uw3p", description=doc.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(doc.splitlines()[2:]))
    parser.add_argument("--version", action="version", version=f"uw3p {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        p = command.add_parser(sub)
        # what error messages call each option (argparse keeps a parser's actions in
        # ``_actions``; it has no public listing)
        p.set_defaults(option_names={a.dest: max(a.option_strings, key=len)
                                     for a in p._actions if a.option_strings})
    return parser


#: Library argument names that are not option destinations, and what the command line calls
#: them.
RENAMES = {"illuminance_lux": "--lux", "exposure_mode": "--exposure",
           "wavelengths": "--wl-min/--wl-max/--step"}


def _message(args, exc) -> str:
    """The error message of ``exc`` in the command's terms (option names, the grid hint)."""
    options = getattr(args, "option_names", {})
    msg = option_message(str(exc), options, RENAMES)
    if "use a grid inside the data" in msg:
        msg += (" with --wl-min/--wl-max" if "wl_min" in options else
                f" (uw3p {args.command} uses 400-700 nm: give curves that cover it, or that fall "
                "to 0 where they stop)")
    return msg


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
    """Run the ``uw3p`` command (the console entry point).

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``uw3p``; default ``sys.argv[1:]``.
    out : text stream, optional
        Standard output (default ``sys.stdout``). The output of a buffered command
        (``BUFFERED`` in its module) is written here when the command ends.
    err : text stream, optional
        Messages and errors (default ``sys.stderr``).

    Returns
    -------
    int
        Exit status: 0 success, 1 an estimate not reliable or not converged, 2 bad input (the
        message, ``uw3p <command>: error: ...``, names the argument or file), 130 interrupted.
        A usage error is reported by argparse, which exits with status 2 (``SystemExit``).
    """
    out = sys.stdout if out is None else out
    err = sys.stderr if err is None else err
    args = build_parser().parse_args(argv)  # usage errors: argparse prints them and exits 2
    #: recorded in the outputs' audit trail
    args.command_line = shlex.join(["uw3p", *(sys.argv[1:] if argv is None else argv)])
    buffered = {command.NAME for command in COMMANDS if command.BUFFERED}
    buf = io.StringIO() if args.command in buffered else out
    try:
        code = int(args.func(args, buf, err) or 0)
    except ValueError as exc:
        err.write(f"uw3p {args.command}: error: {_message(args, exc)}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        err.write(f"uw3p {args.command}: interrupted\n")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return _emit("", out, EXIT_OK)
    return _emit(buf.getvalue(), out, code) if buf is not out else code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
