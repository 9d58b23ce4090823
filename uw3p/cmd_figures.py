"""``uw3p figures``: regenerate Figs 3-13 and the noise study (what ``make reproduce-figures``
runs).

    uw3p figures [NAMES...] [--grid reduced] [--out figures] [--report REPRODUCTION.md]

A thin front to ``python -m experiments``; its output is not buffered (progress is shown as it
comes). It runs from the repository (a checkout, ``pip install -e .``), not from the installed
wheel, which does not ship ``experiments`` (decision 0082-installed-packages): there it exits 2
saying so.
"""

from __future__ import annotations

from .common import EXIT_OK, replication_root

__all__ = ["NAME", "BUFFERED", "add_parser", "run"]

#: The subcommand's name.
NAME = "figures"
#: Output goes straight to the terminal (long runs show their progress).
BUFFERED = False


def add_parser(sub):
    """Register ``figures`` and its options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``uw3p`` parser's subcommands.

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser, its ``func`` default set to :func:`run`.
    """
    p = sub.add_parser(NAME, help="regenerate Figs 3-13 and the noise study (make reproduce-figures)")
    p.add_argument("names", nargs="*", help="a subset of the figure scripts (default all)")
    p.add_argument("--out", default="figures", help="output folder (default figures/)")
    p.add_argument("--grid", default=None, choices=["paper", "reduced"], help="sweep grid (default paper)")
    p.add_argument("--cache", default=None, help="result cache folder (default cache/)")
    p.add_argument("--workers", type=int, default=None, help="processes (default 2)")
    p.add_argument("--setting", default=None, choices=["default", "paper-like"],
                   help="one sensor setting (default: both, into OUT/<setting>/)")
    p.add_argument("--report", default=None, metavar="FILE",
                   help="rewrite the generated tables of FILE (REPRODUCTION.md)")
    p.set_defaults(func=run)
    return p


def run(args, out, err) -> int:
    """Run the figure scripts through ``experiments.__main__.main``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed options: ``names``, ``out``, ``grid``, ``cache``, ``workers``, ``setting``,
        ``report``; those given are passed on.
    out, err : text streams
        Unused (the scripts write to the process's own streams).

    Returns
    -------
    int
        ``EXIT_OK``.

    Raises
    ------
    forward.InputError
        When ``experiments`` is not there (the installed wheel, not a checkout).
    """
    replication_root(NAME)
    from experiments.__main__ import main as figures_main

    argv = list(args.names) + ["--out", args.out]
    for opt in ("grid", "cache", "workers", "setting", "report"):
        if getattr(args, opt) is not None:
            argv += [f"--{opt}", str(getattr(args, opt))]
    figures_main(argv)
    return EXIT_OK
