"""Tiny benchmark protocols for the tests: a shipped protocol at 64 x 64 with few jitter
levels, two episodes a track and one clip a stimulus (and, v2, a scenario and level)."""

from __future__ import annotations

import re
from pathlib import Path

from lgmd_sim.benchmark import protocol

#: version -> its cuts (text replaced), its reference distances (one per level kept), and
#: how many lines a change replaces (v2's sections repeat keys: the first only; v1: all)
_CUTS = {
    "v1": ({"jitter = [0.0, 1.0, 2.0]": "jitter = [1.0]", "jitter = [0.0, 1.0]": "jitter = [1.0]",
            "episodes = 40": "episodes = 2"}, "[3.0]", 0),
    "v2": ({"jitter = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0]": "jitter = [0.0, 2.0]",
            "jitter = [0.0, 1.0]": "jitter = [1.0]", "episodes = 20": "episodes = 2",
            "clips = 6": "clips = 1"}, "[3.0, 3.0]", 1),
}


def tiny_protocol(tmp_path: Path, version: str = "v1", /, **changes: str) -> Path:
    """Protocol `version` cut small, written into `tmp_path`: v1 at jitter 1, v2 at 0 and 2;
    `changes` replace whole lines ("key = value") of it."""
    cuts, distances, count = _CUTS[version]
    text = protocol.PROTOCOLS[version].read_text()
    for old, new in {'resolution = "rl"': 'resolution = "small"', **cuts,
                     "clips = 20": "clips = 1", "bootstrap = 2000": "bootstrap = 200"}.items():
        text = text.replace(old, new)
    text = re.sub(r"reference_distance_m = \[.*\]", f"reference_distance_m = {distances}", text)
    for old, new in changes.items():
        text = re.sub(rf"(?m)^{re.escape(old)} = .*$", new, text, count=count)
    file = tmp_path / f"tiny-{version}.toml"
    file.write_text(text)
    return file
