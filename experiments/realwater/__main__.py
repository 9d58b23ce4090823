"""``python -m experiments.realwater`` (``make real-data``): every real-data experiment and
REALWATER.md at the repository root.

Exit status 2 (with a message) when ``../shared/realdata`` is absent: the target is for
machines with the data.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import traceback
from pathlib import Path

from .nomad_data import realdata_dir
from .report import header, write_report

#: The sections, in order: (module, title). Missing modules are reported as missing.
SECTIONS = (("nomad", "NOMAD v2"), ("casts", "COPS casts"), ("g7x", "Canon G7X photographs"),
            ("phyto", "Phytoplankton absorption"))
ROOT = Path(__file__).resolve().parents[2]


def _lead(numbers: dict) -> str:
    """The report's first paragraph: the held-out comparison's headline
    (:func:`experiments.realwater.empirical.headline`; '' when the NOMAD section failed)."""
    empirical = numbers.get("nomad", {}).get("empirical")
    if not empirical:
        return ""
    from .empirical import headline

    return headline(empirical)


def main(argv=None) -> int:
    """Run every section; write REALWATER.md and figures/realwater/. Returns the exit status."""
    ap = argparse.ArgumentParser(prog="python -m experiments.realwater", description=__doc__)
    ap.add_argument("--out", default=str(ROOT / "figures" / "realwater"),
                    help="folder of the figures and CSVs (default figures/realwater)")
    ap.add_argument("--report", default=str(ROOT / "REALWATER.md"), help="report file")
    args = ap.parse_args(argv)
    if not realdata_dir().is_dir():
        print(f"real data absent: {realdata_dir()} does not exist; `make real-data` needs "
              "../shared/realdata beside the repository", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sections, numbers, failed = [], {}, False
    for name, title in SECTIONS:
        try:
            module = importlib.import_module(f"{__package__}.{name}")
        except ImportError as exc:
            sections.append(f"## {title}\n\nSection missing: `experiments/realwater/{name}.py` "
                            f"could not be imported ({exc}).\n")
            continue
        try:
            md, nums = module.run(out)
        except Exception:  # noqa: BLE001 -- reported in the file and on stderr, never hidden
            failed = True
            tb = traceback.format_exc()
            print(tb, file=sys.stderr)
            sections.append(f"## {title}\n\n**Failed**:\n\n```\n{tb.strip()}\n```\n")
            continue
        print(f"{name}: done", file=sys.stderr)
        sections.append(md)
        numbers[name] = nums
    write_report(Path(args.report), sections, numbers, out / "realwater.json",
                 header=header(_lead(numbers)))
    print(f"wrote {args.report}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
