"""docs/reference/models.md lists each model's presets as the code has them."""

from __future__ import annotations

import re
from pathlib import Path

from lgmd_sim import models

PAGE = Path(__file__).resolve().parents[2] / "docs" / "reference" / "models.md"


def test_the_presets_table_lists_each_model_s_presets():
    section = PAGE.read_text().split("\n## Presets\n")[1].split("\n## ")[0]
    rows = {m[1]: m[2] for m in re.finditer(r"^\| `(\w+)` \|(.*)$", section, re.M)}
    # the built-ins: a test may have registered a model of its own
    assert list(rows) == models.available()[:5] == ["feedback", "lgmd1", "lgmd2", "f_on",
                                                   "f_off"]
    for name, cells in rows.items():
        listed = set(re.findall(r"`([\w.-]+)`", cells))
        own = set(models.presets_of(name))
        assert listed <= own, (name, listed - own)
        # the open-loop controls are named as a family, every other preset one by one
        assert {p for p in own if "open-loop" not in p} <= listed, (name, own - listed)
