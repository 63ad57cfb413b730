"""The research log's generators write where its pages are: the sections that
docs/experiments/tools/robot_page.py and docs/experiments/tools/video_page.py splice into a page
find their markers there, once (a page moved without them would get a second copy appended)."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

# The research log's tools (docs/experiments/tools/): the slow tier, out of the edit loop.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[4]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


@pytest.mark.parametrize(("script", "page"), [("robot_page", "OUT"), ("video_page", "PAGE")])
def test_a_generated_section_s_markers_stand_once_in_its_page(script, page):
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(TOOLS))
        module = importlib.import_module(script)
    text = getattr(module, page).read_text()
    assert text.count(module.BEGIN) == 1 and text.count(module.END) == 1
    assert text.index(module.BEGIN) < text.index(module.END)
