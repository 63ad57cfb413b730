"""The models a detection runs, from a command's words: a preset for every model that has
it, and the front ends a video can have."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from lgmd_sim import models
from lgmd_sim.models.base import LGMDModel

__all__ = ["VIDEO_FRONT_ENDS", "front_end_params", "with_preset"]


def with_preset(names: Sequence[str], preset: str | None, **front: Any
                ) -> dict[str, LGMDModel]:
    """The models `names`, each at `preset` where it has one (named "model/preset"), else
    at its default (named "model"); ``front`` (`front_end_params`) gives each the same
    ego-motion compensation."""
    if preset is not None and not any(preset in models.presets_of(n) for n in names):
        raise ValueError(f"none of the models {', '.join(names)} has a preset {preset!r}")
    built = {}
    for name in names:
        if preset is not None and preset in models.presets_of(name):
            built[f"{name}/{preset}"] = models.make(name, preset=preset, **front)
        else:
            built[name] = models.make(name, **front)
    return built


#: The front ends a video can have: its frames are all there is (no pose, no IMU).
VIDEO_FRONT_ENDS = ("image", "gain")


def front_end_params(stabilize: str | None, fovy: float) -> dict[str, Any]:
    """Model parameters of front ends for videos, "+"-separated: "image" (the camera's
    rotation between frames, fitted from the frames, with the vertical field of view
    `fovy` in degrees), "gain" (the brightness gain between frames) or "image+gain";
    None or "none": {} (none)."""
    if stabilize is None or stabilize == "none":
        return {}
    given = stabilize.split("+")
    if any(f not in VIDEO_FRONT_ENDS for f in given) or len(set(given)) < len(given):
        raise ValueError(f"--stabilize {stabilize!r}: give image, gain or image+gain (a video "
                         "has no pose or IMU to take the rotation from)")
    return {"stabilize": "image" if "image" in given else "none", "gain": "gain" in given,
            "fovy": fovy}
