"""Issue 50 item 6: same-code validations labelled so, the bounds' sensitivity to the per-patch
term, one source for every timing."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

from experiments import benchmark_report, instrument

ROOT = Path(__file__).resolve().parents[1]


def test_budget_table_covers_the_per_patch_levels_and_widens_with_them():
    rows = [r for r in instrument.budget_table() if r["water"] == "coastal" and r["depth"] == 10]
    assert rows
    chl = [rows[0]["chl_rel95_patch"][v] for v in instrument.PATCH_LEVELS]
    c = [rows[0]["c_rel95_patch"][v] for v in instrument.PATCH_LEVELS]
    assert set(instrument.PATCH_LEVELS) == {0.01, 0.03, 0.10, 0.20}
    assert chl == sorted(chl) and c == sorted(c) and c[-1] > 2 * c[0]
    assert abs(chl[0] - rows[0]["chl_rel95_budget"]) < 1e-9  # 1 % is the budget's own
    text = "\n".join(instrument._budget_section(rows))
    assert "Sensitivity to the per-patch term" in text
    assert all(f"c, {100 * v:g} %" in text for v in instrument.PATCH_LEVELS)


def test_same_code_validations_are_labelled():
    src = inspect.getsource(instrument)
    assert "## Validation (same code)" in src and "rate with depth in Fig 12? (same code)" not in src
    assert "Fig 12? (same code)" in src
    bench = inspect.getsource(benchmark_report)
    assert "RRMSE(k) median (same code)" in bench and "rel err C median / max (same code)" in bench
    assert "Interval coverage (95 % profile likelihood; same code)" in bench


def test_reproduction_quotes_no_timing_of_its_own():
    text = (ROOT / "REPRODUCTION.md").read_text()
    hand = re.sub(r"<!-- (generated|outcome):begin -->.*?<!-- \1:end -->", "", text, flags=re.S)
    assert "benchmarks/make_times.json" in hand
    assert "| what | wall time |" not in hand
    assert not re.search(r"\*\*\d[\d ]* s\*\*", hand)
