"""The models a detection runs, from a command's words: a preset for every model that has
it, and the front ends a video can have."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from lgmd_sim import models
from lgmd_sim.core.params import FieldError
from lgmd_sim.models.base import LGMDModel

__all__ = ["VIDEO_FRONT_ENDS", "detector", "detector_names", "front_end_params", "model_of",
           "with_preset"]


def model_of(name: str) -> str:
    """The model a detector's name is of ("lgmd1/video+image" -> "lgmd1"; a plug-in's
    "package.module:Class/preset" -> "package.module:Class")."""
    return name.split("+")[0].partition("/")[0]


def detector_names(spec: str | Sequence[str]) -> list[str]:
    """The detectors of "all" (every model), a comma-separated list or a sequence, each
    MODEL[/PRESET][+FRONT...] (`detector`), repeats dropped; their models are checked
    here, an unknown one named with the valid ones (`lgmd_sim.controllers.options.model_names`)."""
    from lgmd_sim.controllers import options

    given = options.comma_list(spec) if isinstance(spec, str) else [
        str(t).strip() for t in spec if str(t).strip()]
    names = options.model_names([model_of(t) for t in given])
    return names if given == ["all"] else list(dict.fromkeys(given))


def detector(token: str, preset: str | None, fov: float | None = None, **front: Any
             ) -> tuple[str, str, str | None, dict[str, Any]]:
    """What `with_preset` builds of one detector as a command names it: (the name its
    outputs carry, the model, its preset, its parameter overrides).

    `token` is MODEL, MODEL/PRESET or either with front ends (`VIDEO_FRONT_ENDS`:
    "lgmd1/robot+gain"), as everywhere (`lgmd_sim.models.parse_spec`). `preset` goes to a
    model listed without one, where it has it (a plain MODEL then runs at its default,
    named "model"); a model listed with another is refused, as is one listed with front
    ends when ``front`` gives every model its own.

    Raises:
        ValueError: an unknown model, preset or front end, or those conflicts, in one
            line naming the detector.
    """
    head, *fronts = token.strip().split("+")
    name, _, own = head.partition("/")
    if own and preset is not None and own != preset:
        raise ValueError(f"detector {token!r} names preset {own!r}, --preset {preset!r}: "
                         "give a model's preset once, in --models or in --preset")
    if not own:
        own = preset if preset is not None and preset in models.presets_of(name) else ""
    if not fronts:  # the front ends of the command, if any
        return (f"{name}/{own}" if own else name), name, own or None, dict(front)
    if front:
        raise ValueError(f"detector {token!r} names its front ends and --stabilize gives "
                         "every model its own: give them once, in --models or in --stabilize")
    video = [f for f in fronts if f not in VIDEO_FRONT_ENDS]
    if video:
        raise ValueError(f"detector {token!r}: a video has no pose or IMU, so its front ends "
                         f"are {', '.join('+' + f for f in VIDEO_FRONT_ENDS)}, not "
                         f"{', '.join('+' + f for f in video)}")
    model, full = models.parse_spec("+".join([f"{name}/{own}" if own else name, *fronts]))
    # the camera's field of view, which the rotation fitted from the frames needs
    fitted = {"fovy": fov} if "image" in fronts and fov is not None else {}
    return f"{model}/{full}", model, full, fitted


def with_preset(names: Sequence[str], preset: str | None, fov: float | None = None,
                **front: Any) -> dict[str, LGMDModel]:
    """The models `names`, each at `preset` where it has one (named "model/preset"), else
    at its default (named "model"); ``front`` (`front_end_params`) gives each the same
    ego-motion compensation. A name may carry its own preset and video front ends
    ("lgmd1/robot+image", named in full: "lgmd1/robot+image"; `detector` says the rules),
    its "+image" with the vertical field of view `fov` (degrees; None: the model's)."""
    built = {d[0]: d for d in (detector(n, preset, fov, **front) for n in names)}
    bare = [n for n in names if "/" not in n]
    if preset is not None and bare and not any(preset in models.presets_of(
            n.partition("+")[0]) for n in bare):
        raise ValueError(f"none of the models {', '.join(bare)} has a preset {preset!r}")
    return {key: models.make(model, preset=at, **params)
            for key, model, at, params in built.values()}


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
        raise FieldError("stabilize", "must be image, gain or image+gain (a video has no pose "
                         f"or IMU to take the rotation from), got {stabilize!r}")
    return {"stabilize": "image" if "image" in given else "none", "gain": "gain" in given,
            "fovy": fovy}
