"""Optional dependencies ("extras"): a clear error naming the extra when one is missing.

>>> from lgmd_sim.core.extras import require
>>> sb3 = require("stable_baselines3", "rl")   # the module, or MissingExtra
"""

from __future__ import annotations

from importlib import import_module
from types import ModuleType

#: What each extra of the package brings (the README lists the same).
EXTRAS = {
    "rl": "stable-baselines3 and PyTorch (CPU build): training and evaluating policies",
    "ray": "Ray: benchmarks and dataset generation as tasks on a cluster (--workers ray)",
    "data": "pyarrow: labelled datasets with per-frame labels in Parquet",
    "lerobot": "PyAV and pyarrow: lgmd-sim dataset export --format lerobot (H.264/AV1 MP4 videos)",
    "video": "moviepy: Gymnasium's RecordVideo wrapper (recording episodes)",
    "dev": "pytest and ruff: the test suite and the linter",
}


def install_command(extra: str) -> str:
    """How a user installs `extra`: lgmd-sim is not on the package index, so from a
    checkout, with the constraints that keep PyTorch to its CPU build."""
    return f"from a checkout of lgmd-sim: pip install -c constraints.txt '.[{extra}]'"


class MissingExtra(ImportError):
    """An optional dependency is not installed; the message says which extra brings it."""


def require(module: str, extra: str) -> ModuleType:
    """Import `module`, or raise MissingExtra naming the extra to install."""
    try:
        return import_module(module)
    except ImportError as exc:
        raise MissingExtra(f"this needs {module.split('.')[0]}, which comes with the "
                           f"'{extra}' extra; install it {install_command(extra)}") from exc
