"""Presets that come from data files rather than code: ``calibrated.json``, written by
``lgmd-sim calibrate --save-presets`` with the command, seeds, objective and figure that
produced each preset (docs/results.md shows them)."""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["CALIBRATED", "data_presets"]

#: The calibrated presets of every model (absent until a calibration saved them).
CALIBRATED = Path(__file__).with_name("calibrated.json")


@functools.cache
def _load() -> dict[str, Any]:
    if not CALIBRATED.is_file():
        return {}
    return json.loads(CALIBRATED.read_text())


def data_presets(model: str, own: Mapping[str, Mapping[str, Any]]
                 ) -> dict[str, dict[str, Any]]:
    """The data-file presets of `model`, each resolved against the model's own preset it
    starts from (its "from")."""
    out = {}
    for name, entry in _load().get("presets", {}).get(model, {}).items():
        out[name] = {**own[entry["from"]], **entry["params"]}
    return out
