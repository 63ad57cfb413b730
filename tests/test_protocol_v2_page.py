"""docs/experiments/tools/protocol_v2.py: the record of protocol v2 is what the tool makes
from today's rows, and its figures are the rows' (the research log's slow tier)."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT / "docs" / "experiments" / "tools"


@pytest.fixture(scope="module")
def tool():
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(TOOLS))
        yield importlib.import_module("protocol_v2")


def test_the_record_is_what_the_rows_make_now(tool):
    made = tool.page()
    assert made == (ROOT / "docs/experiments/protocol-v2.md").read_text(), (
        "docs/experiments/protocol-v2.md is stale: python docs/experiments/tools/protocol_v2.py")


def test_spearman_is_computed_over_the_detector_rows_only(tool):
    rows = [{"scores": {"detection": d, "overall": o}} for d, o in
            ((0.1, 0.1), (0.2, 0.3), (0.3, 0.2), (0.4, 0.4))]
    rows.append({"scores": {"overall": 0.9}})  # a controller: no detection score
    rho, n = tool._rho(rows, "detection")
    assert n == 4 and rho == pytest.approx(0.8)
    assert tool._rho(rows[:2], "detection") is None  # too few to rank
