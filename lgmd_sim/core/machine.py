"""The machine a run or a benchmark ran on, for its record."""

from __future__ import annotations

import os
import platform
from typing import Any

__all__ = ["cpu_name", "machine"]


def cpu_name() -> str:
    """The CPU's model name."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict[str, Any]:
    """CPU, cores, Python, platform and the numeric mode (`lgmd_sim.core.numerics`): what a
    run's record says it ran on."""
    from lgmd_sim.core.numerics import mode

    return {"cpu": cpu_name(), "cores": os.cpu_count(), "python": platform.python_version(),
            "platform": platform.platform(), "numerics": mode()}
