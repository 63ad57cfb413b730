"""Straightforward per-equation reference implementations of the LGMD models.

Each is written for clarity, in float64 on whole frames with explicit histories: the
oracle the fast kernels are tested against, and the baseline of ``lgmd-sim bench
models``. They share the fast models' parameters, presets and interface.
`lgmd_sim.models.reference.published` holds something else: ports of the published
baseline code itself, the oracles of the baselines' ``published`` presets.

>>> from lgmd_sim.models.reference import make_reference
>>> ref = make_reference("feedback", feedback_gain=100.0)
"""

from __future__ import annotations

from typing import Any

from lgmd_sim import models
from lgmd_sim.core.registry import Registry
from lgmd_sim.models.base import LGMDModel

__all__ = ["available_references", "make_reference"]

# model name -> "module:class"; imported on first use, so a reference whose module is not
# written yet only fails when asked for.
_REFERENCES = Registry("reference implementation", LGMDModel, {
    "feedback": "lgmd_sim.models.reference.feedback:FeedbackReference",
    "lgmd1": "lgmd_sim.models.reference.baselines:LGMD1Reference",
    "lgmd2": "lgmd_sim.models.reference.baselines:LGMD2Reference",
    "f_on": "lgmd_sim.models.reference.baselines:FOnReference",
    "f_off": "lgmd_sim.models.reference.baselines:FOffReference",
})


def available_references() -> list[str]:
    """Model names that have a reference implementation registered."""
    return _REFERENCES.names()


def make_reference(
    name: str, *, preset: str | None = None, n_streams: int | None = None, **params: Any
) -> LGMDModel:
    """The reference implementation of model `name`, configured as `models.make` would.

    Raises:
        ValueError: unknown model, preset or parameter, or no reference available for it.
    """
    params_of = models.make(name, preset=preset, **params).params  # checks every argument
    if name not in _REFERENCES.builtins:  # a model spec is no reference implementation
        raise ValueError(f"no reference implementation registered for model {name!r}")
    return _REFERENCES.get(name)(params_of, n_streams=n_streams)
