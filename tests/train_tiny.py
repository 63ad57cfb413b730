"""What the training tests share: a tiny run's --config file."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any


def config_option(path: Path, keys: Mapping[str, Any]) -> list[str]:
    """``--config PATH``, the file written with `keys` (`TrainConfig`'s fields)."""
    from lgmd_sim.core.configfile import config_toml
    from lgmd_sim.training.config import TrainConfig

    path.write_text(config_toml(TrainConfig, keys))
    return ["--config", str(path)]
