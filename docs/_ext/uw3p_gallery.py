"""A gallery made from the figure scripts (``experiments.FIGURES`` and ``STUDIES``): one page per
script with its docstring, the figures it made and its source.

The figures are looked up in the ``uw3p_figures`` folder of ``conf.py`` (``make docs`` makes them
on the reduced grid first, ``uw3p figures --grid reduced``; after ``make reproduce-figures`` the
paper's grid is in ``figures/``). A script whose figures are not there gets a page that says so,
never an empty picture.
"""

from __future__ import annotations

import importlib
import re
import shutil
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def _prefix(name: str) -> str:
    """The file-name prefix of a script's figures: ``fig12_chlorophyll_estimates`` ->
    ``fig12``, ``fig05_06_appearance_sites`` -> ``fig05_06``, a study its own name."""
    m = re.match(r"(fig\d\d(?:_\d\d)?)", name)
    return m.group(1) if m else name


def _figures(root: Path, name: str) -> list[Path]:
    found = []
    for folder in (root / "default", root):
        found += sorted(folder.glob(_prefix(name) + "*.png"))
    return found


def _page(name: str, root: Path, images: Path) -> str:
    mod = importlib.import_module(f"experiments.{name}")
    lines = [f"# {name}", "", "```{eval-rst}", (mod.__doc__ or "").strip(), "```", ""]
    figs = _figures(root, name)
    if figs:
        for f in figs:
            target = images / f"{f.parent.name}_{f.name}"
            shutil.copyfile(f, target)
            lines += [f"![{f.name}](_images/{target.name})", "",
                      f"*{f.name}* (from `{f.parent}`)", ""]
    else:
        lines += ["```{note}", f"No figure of this script in `{root}`: run "
                  "`make reproduce-figures` or `make docs`.", "```", ""]
    lines += ["## Source", "", f"```{{literalinclude}} ../../experiments/{name}.py",
              ":language: python", "```", ""]
    return "\n".join(lines)


def generate(app) -> None:
    """Write ``gallery/`` before the build reads its sources."""
    from experiments.__main__ import FIGURES, STUDIES

    root = Path(app.config.uw3p_figures)
    out = HERE / "gallery"
    images = out / "_images"
    shutil.rmtree(out, ignore_errors=True)
    images.mkdir(parents=True)
    names = FIGURES + STUDIES
    for name in names:
        (out / f"{name}.md").write_text(_page(name, root, images), encoding="utf-8")
    index = ["# Gallery", "",
             "The paper's figures as uw3p regenerates them, one page per script of "
             "`experiments/` (`uw3p figures`; `make reproduce-figures` runs the paper's grid, "
             f"`make docs` the reduced one). Figures from `{root}`.", "",
             "```{toctree}", ":maxdepth: 1", ""] + names + ["```", ""]
    (out / "index.md").write_text("\n".join(index), encoding="utf-8")


def setup(app):
    app.add_config_value("uw3p_figures", "figures", "env")
    app.connect("builder-inited", generate)
    return {"parallel_read_safe": True}
