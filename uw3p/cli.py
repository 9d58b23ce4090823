"""The ``uw3p`` command: simulate a chart, estimate the water, regenerate figures, benchmark.

    uw3p simulate --chl 1 --cdom 0.1 --depth 10 --distance 5 [--out sim.json|m.csv]
    uw3p estimate m.csv --depth 10 --distance 5 [--json] [--attenuation k.csv] [--gain free]
    uw3p estimate --batch charts.csv --distance 5 [--json] [--attenuation k.csv]
    uw3p design --chl 1 --cdom 0.1 --depth 2 15 --distance 1 3 [--target C=30%] [--plan dive.csv]
    uw3p calibrate AIR.dng --corners "x1,y1 x2,y2 x3,y3 x4,y4" --out profile.json
    uw3p measure UW.dng --profile profile.json --depth 5 --distance 1.5 --corners "..." --out DIR
    uw3p correct PHOTO.dng --water DIR/measurement.json --range map.tif --out CORRECTED
    uw3p figures [--grid reduced] [--out figures]      (what `make reproduce-figures` runs)
    uw3p bench [--quick]                               (what `make bench` runs)
    uw3p --version

Exit status: 0 success (``estimate``, ``measure``: every estimate is reliable; ``calibrate``: the
profile fits; ``design``: a protocol meets every target, by default C to ±30 % at 95 %), 1 an
estimate is not reliable or did not converge (its flags say why; ``design``: no protocol
searched meets the targets), 2 bad input (the message names the argument
or file; an unknown option or subcommand with the closest valid one), 130 interrupted.
``estimate`` needs the noise (``red_sd,green_sd,blue_sd`` columns, as
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
import re
import shlex
import os
import sys

from . import (__version__, cmd_bench, cmd_calibrate, cmd_correct, cmd_design, cmd_estimate,
               cmd_figures, cmd_measure, cmd_simulate)
from .common import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_OK, option_message, plain

__all__ = ["COMMANDS", "Parser", "build_parser", "main"]

#: The subcommand modules, in the order ``uw3p --help`` lists them. Each has ``NAME``,
#: ``BUFFERED`` (output collected and written at the end), ``add_parser(sub)`` and
#: ``run(args, out, err) -> exit status``; a new subcommand is a new module added here.
COMMANDS = (cmd_simulate, cmd_calibrate, cmd_measure, cmd_correct, cmd_estimate, cmd_design,
            cmd_figures, cmd_bench)


#: What argparse takes for a negative number, not an option (its own rule).
NEGATIVE_NUMBER = re.compile(r"-\d+|-\d*\.\d+")
#: How many of the closest options or choices a usage error suggests (difflib's order: the
#: most similar first; more than one tends to add an unrelated name).
SUGGESTIONS = 1
#: argparse's message for required arguments that are missing.
REQUIRED_MESSAGE = "the following arguments are required"


class Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors suggest what was meant.

    An unknown option is reported by the subcommand's parser (its usage, ``uw3p <command>:
    error: unrecognized arguments: --metdata (did you mean --metadata?)``), with the closest
    options of that subcommand (:func:`difflib.get_close_matches`) or the subcommands it
    belongs to; an invalid choice (a subcommand's name, ``--tiff``'s value) with the closest
    choices. Python 3.14's ``suggest_on_error`` does the latter only.
    """

    #: Subcommand name -> its parser, shared by the ``uw3p`` parser and its subcommands'
    #: (set by :func:`build_parser`).
    commands: dict = {}

    def parse_known_args(self, args=None, namespace=None):
        """argparse's, the arguments kept for :meth:`error`."""
        self._given = list(sys.argv[1:] if args is None else args)  # for error()
        return super().parse_known_args(args, namespace)

    def parse_args(self, args=None, namespace=None):
        """argparse's; unrecognized arguments reported by the subcommand's parser."""
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            parser = self.commands.get(getattr(namespace, "command", None), self)
            parser.error(f"unrecognized arguments: {parser._explain(extras)}")
        return namespace

    def error(self, message):
        """argparse's (the usage and ``message``, exit 2); unknown options first."""
        if message.startswith(REQUIRED_MESSAGE):  # an unknown option may be why
            unknown = [a for a in getattr(self, "_given", ()) if self._unknown(a)]
            if unknown:
                message = f"unrecognized arguments: {self._explain(unknown)}; {message}"
        super().error(message)

    def _options(self):
        return [s for a in self._actions for s in a.option_strings]

    def _unknown(self, arg) -> bool:
        """Whether argparse takes ``arg`` for an option this parser does not have."""
        if not arg.startswith("-") or arg in ("-", "--") or " " in arg \
                or NEGATIVE_NUMBER.fullmatch(arg):
            return False
        name = arg.split("=", 1)[0]
        return not any(o == name or (name.startswith("--") and o.startswith(name))
                       for o in self._options())  # argparse takes unique prefixes

    def _explain(self, args) -> str:
        """The unrecognized arguments, each unknown option followed by what was meant."""
        words = []
        for arg in args:
            name = arg.split("=", 1)[0]
            hints = []
            if self._unknown(arg):
                owners = [c for c, p in self.commands.items() if p is not self
                          and name in p._options()]
                hints += [f"an option of uw3p {', '.join(owners)}"] if owners else []
                import difflib  # only for a usage error (its import: 0.1 s)

                close = difflib.get_close_matches(name, self._options(), n=SUGGESTIONS)
                hints += [f"did you mean {' or '.join(close)}?"] if close else []
            words.append(f"{arg} ({'; '.join(hints)})" if hints else arg)
        return " ".join(words)

    def _check_value(self, action, value):
        # argparse's check of a choice (a subcommand's name, an option's value), with the
        # closest choices (argparse has no public hook for it)
        try:
            super()._check_value(action, value)
        except argparse.ArgumentError as exc:
            import difflib

            close = difflib.get_close_matches(str(value), [str(c) for c in action.choices],
                                              n=SUGGESTIONS)
            if not close:
                raise
            head, sep, tail = exc.message.partition(" (choose from")
            meant = " or ".join(repr(c) for c in close)
            raise argparse.ArgumentError(action, f"{head}, did you mean {meant}?{sep}{tail}") \
                from None


def build_parser() -> argparse.ArgumentParser:
    """The ``uw3p`` argument parser with every subcommand of :data:`COMMANDS`.

    Returns
    -------
    argparse.ArgumentParser
        Parsing sets ``command`` (the subcommand's name) and ``func`` (its ``run``).
    """
    doc = plain(__doc__)
    parser = Parser(prog="uw3p", description=doc.splitlines()[0],
                    formatter_class=argparse.RawDescriptionHelpFormatter,
                    epilog="\n".join(doc.splitlines()[2:]))
    parser.add_argument("--version", action="version", version=f"uw3p {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)  # each a Parser
    parser.commands = {}
    for command in COMMANDS:
        p = parser.commands[command.NAME] = command.add_parser(sub)
        p.commands = parser.commands
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
    msg = option_message(exc, options, RENAMES)
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
