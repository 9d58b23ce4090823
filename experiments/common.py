"""Shared helpers of the figure scripts: output folder, saving PNG + PDF, CSV writing."""

from __future__ import annotations

import csv
import os
import subprocess
from pathlib import Path

import matplotlib

from forward.files import atomic_open, atomic_path
from measure.csvsafe import safe_writer

matplotlib.use("Agg")  # the figure scripts draw to files only

__all__ = ["WORKTREE", "commit_of", "figures_dir", "read_csv", "save_figure", "write_csv", "style", "percent_axis", "DPI",
           "MIN_FONT_PT"]


def figures_dir(outdir=None) -> Path:
    """The output folder, created if missing: ``outdir``, else the environment variable
    UW3P_FIGURES, else ``figures/`` in the current directory."""
    path = Path(outdir or os.environ.get("UW3P_FIGURES", "figures"))
    path.mkdir(parents=True, exist_ok=True)
    return path


#: PNG resolution: figures are drawn 4.5-7.5 in wide, so PNGs are >= 1350 px wide.
DPI = 300
#: Smallest font size at print size (pt).
MIN_FONT_PT = 8


def style():
    """Matplotlib settings of every figure: fonts >= 8 pt at print size."""
    import matplotlib as mpl

    mpl.rcParams.update({"font.size": 9, "axes.titlesize": 9, "axes.labelsize": 9,
                         "xtick.labelsize": 8, "ytick.labelsize": 8, "legend.fontsize": 8,
                         "figure.titlesize": 10})


def percent_axis(ax, axis="y"):
    """Tick labels of a logarithmic axis of fractions written as percentages ("0.02 %", not a
    bare 10^-2 beside a "%" unit), at 1, 2 and 5 of every decade."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    a = ax.yaxis if axis == "y" else ax.xaxis
    a.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    a.set_major_formatter(FuncFormatter(lambda v, _: f"{100 * v:.3g} %"))
    a.set_minor_formatter(NullFormatter())


def save_figure(fig, name: str, outdir=None) -> list[Path]:
    """Save ``fig`` as ``name``.png (``DPI``) and ``name``.pdf; returns the paths. A figure
    with a layout engine (every figure here: constrained layout) already fits its canvas and is
    saved as laid out (a "tight" bounding box would draw it twice more per file); others are
    cropped to their tight bounding box."""
    out = figures_dir(outdir)
    paths = [out / f"{name}.png", out / f"{name}.pdf"]
    tight = None if fig.get_layout_engine() is not None else "tight"
    for p in paths:
        with atomic_path(p) as tmp:
            fig.savefig(tmp, format=p.suffix[1:], dpi=DPI, bbox_inches=tight,
                        metadata=_metadata(p.suffix))
    return paths


def _metadata(suffix):
    # fixed metadata so reruns write identical files
    if suffix == ".pdf":
        return {"CreationDate": None, "Creator": "uw3p", "Producer": "uw3p"}
    return {"Software": "uw3p"}


def read_csv(path) -> list[dict]:
    """The rows of a CSV that :func:`write_csv` wrote (its ``#`` comment lines skipped)."""
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def write_csv(path: Path, header: list[str], rows, comment: str | None = None) -> Path:
    """Write rows to ``path`` atomically; ``comment`` lines go first, prefixed with '#'."""
    path = Path(path)
    with atomic_open(path, "w", newline="", encoding="utf-8") as f:
        if comment:
            for line in comment.splitlines():
                f.write(f"# {line}\n")
        w = safe_writer(f, lineterminator="\n")
        w.writerow(header)
        for row in rows:
            w.writerow(row)
    return path


#: The repository the experiments run in (``git`` commands).
_ROOT = Path(__file__).resolve().parents[1]
#: ``commit_of``'s name of the working tree.
WORKTREE = "WORKTREE"


def commit_of(rev: str) -> str:
    """The full hash of ``rev`` (``WORKTREE``: HEAD's, with '+changes' where the tree differs
    from it)."""
    if rev == WORKTREE:
        head = commit_of("HEAD")
        dirty = subprocess.run(["git", "-C", str(_ROOT), "status", "--porcelain",
                                "--untracked-files=no"], check=True, capture_output=True,
                               text=True).stdout.strip()
        return head + ("+changes" if dirty else "")
    return subprocess.run(["git", "-C", str(_ROOT), "rev-parse", "--verify", rev + "^{commit}"],
                          check=True, capture_output=True, text=True).stdout.strip()
