"""Which of a model's layer maps tells where in the view it is excited, for what reads that:
ReactiveAvoid's side "halves" (the left and right halves) and the LGMD features' grid (each
cell's share). The contract lets a model declare any layers, or none (``layer_names = ()``),
so a consumer asks here, and refuses a model without layers before any work, in one line.
"""

from __future__ import annotations

from lgmd_sim import models
from lgmd_sim.models.base import LGMDModel

__all__ = ["activity_layer", "needed_layer"]


def activity_layer(cls: type[LGMDModel]) -> str | None:
    """The layer of model class `cls` that tells where in the view it is excited: "S", the
    built-ins' excitation on its way to the LGMD cell, where it has one, else its last
    layer (a plug-in's nearest its potential); None for a model without layers."""
    names = cls.layer_names
    return "S" if "S" in names else names[-1] if names else None


def needed_layer(model: str, reads: str, instead: str) -> str:
    """The `activity_layer` of model `model` (a name or spec), for what `reads` it.

    Args:
        reads: what reads it, as the caller's user spells it, to go before "a layer of
            the model" ("--obs features observes a grid of the activity of").
        instead: what a model without layers can do instead, in the same spelling.

    Raises:
        ValueError: `model` has no layers, in one line saying `reads` and `instead`.
    """
    layer = activity_layer(models.model_class(model))
    if layer is None:
        raise ValueError(f"{reads} a layer of the model (S, or a plug-in's last), and {model} "
                         f"has none (layer_names is empty): {instead}")
    return layer
