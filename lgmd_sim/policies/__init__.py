"""Policies that ship with lgmd-sim, each a policy folder (`lgmd_sim.training.policy`):
``policy.zip``, ``policy.json`` and ``POLICY.md`` (the command that trained it and its
evaluation table).

>>> from lgmd_sim import policies
>>> policies.available(), policies.path(policies.DEFAULT)

``lgmd-sim eval`` with no policy evaluates `DEFAULT`; ``--controllers policy`` in
``lgmd-sim bench closed-loop`` drives with it.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["DEFAULT", "available", "path"]

#: The shipped policy that `lgmd-sim eval` (and the "policy" controller) use by default.
DEFAULT = "sac-feedback"
_HERE = Path(__file__).resolve().parent


def available() -> list[str]:
    """The names of the shipped policies."""
    return sorted(p.parent.name for p in _HERE.glob("*/policy.json"))


def path(name: str) -> Path:
    """The folder of shipped policy `name`."""
    if name not in available():
        raise ValueError(f"no shipped policy {name!r}; shipped: {', '.join(available())}")
    return _HERE / name
