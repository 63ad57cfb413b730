"""docs/experiments/tools/protocol_v2.py: the record of protocol v2 is what the tool makes
from today's rows (the research log's slow tier)."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[4]
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

