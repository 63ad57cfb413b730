"""The LGMD model family behind one interface, chosen by name.

>>> from lgmd_sim import models
>>> models.available()
['feedback', 'lgmd1', 'lgmd2', 'f_on', 'f_off']
>>> m = models.make("feedback")            # the paper's feedback LGMD, preset "paper"
>>> out = m.step(frame)                     # out.potential in [0.5, 1), out.alarm
>>> batch = models.make("lgmd2", n_streams=8)   # 8 independent streams, frames (8, H, W)
>>> m = models.make("lgmd1", preset="published+image")   # with ego-motion compensation

A detector is named "model", "model/preset" or either with front ends appended:
"lgmd1/published+image", "feedback+imu+gain" (`parse_spec`). A front end is a preset
suffix that sets the parameters ``stabilize`` ("+pose", "+imu", "+image") and ``gain``
("+gain"); see `lgmd_sim.models.stabilize`.

A model of your own (an `LGMDModel` subclass: the contract is its docstring) joins in any
of three ways, and is then a model like the built-ins, with its presets and front ends:

- by a "package.module:Class" spec wherever a model name goes:
  ``make("mypkg.looming:Mine", preset="fast+image")``, ``"mypkg.looming:Mine/fast+image"``;
- by a name, from Python: ``register("mine", Mine)`` (or ``register("mine",
  "mypkg.looming:Mine")``, imported on first use);
- by a name, from an installed distribution: an entry point in the group
  ``lgmd_sim.models`` (`ENTRY_POINTS`), its name the model's and its value
  "package.module:Class" (pyproject.toml: ``[project.entry-points."lgmd_sim.models"]``
  ``mine = "mypkg.looming:Mine"``).
"""

from __future__ import annotations

from typing import Any

from lgmd_sim.core.registry import Registry
from lgmd_sim.models.base import (
    RESERVED_PARAMETERS,
    LGMDModel,
    LGMDOutput,
    ModelParams,
    StateMap,
)
from lgmd_sim.models.check import ModelCheckError, check_model
from lgmd_sim.models.guard import PluginError, run_hook
from lgmd_sim.models.search import SearchRange

__all__ = ["ENTRY_POINTS", "FRONT_END_SUFFIXES", "RESERVED_PARAMETERS", "LGMDModel", "LGMDOutput",
           "ModelCheckError", "ModelParams", "PluginError", "SearchRange", "StateMap",
           "available", "check_model", "make", "model_class", "origin", "parse_spec",
           "presets_of", "register"]

#: The entry-point group through which an installed distribution adds models.
ENTRY_POINTS = "lgmd_sim.models"

#: Front ends as preset suffixes ("published+image"), in the order a spec lists them, and
#: the parameters each sets.
FRONT_END_SUFFIXES: dict[str, dict[str, Any]] = {
    "pose": {"stabilize": "pose"},
    "imu": {"stabilize": "imu"},
    "image": {"stabilize": "image"},
    "gain": {"gain": True},
}

# The built-ins as "module:class", imported on first use so that `available()` stays cheap.
_MODELS = Registry("model", LGMDModel, {
    "feedback": "lgmd_sim.models.feedback:FeedbackLGMD",
    "lgmd1": "lgmd_sim.models.lgmd1:LGMD1",
    "lgmd2": "lgmd_sim.models.lgmd2:LGMD2",
    "f_on": "lgmd_sim.models.ffi:FOnLGMD",
    "f_off": "lgmd_sim.models.ffi:FOffLGMD",
}, group=ENTRY_POINTS)


def available() -> list[str]:
    """The model names `make` accepts: the built-ins, then those `register`ed, then those
    of installed distributions (`ENTRY_POINTS`). Any "package.module:Class" spec of an
    `LGMDModel` is accepted as well."""
    return _MODELS.names()


def register(name: str, cls: type[LGMDModel] | str) -> None:
    """Make model `cls` (an `LGMDModel` subclass, or a "package.module:Class" string,
    imported on first use) available as `name`, for this process only: the workers of a
    parallel run (``--workers``) are fresh interpreters that do not see it, so a run
    with workers names the model by its spec or an entry point.

    Raises:
        ValueError: `name` is taken or holds one of ": / + ," or a space, or `cls` is not
            an `LGMDModel` subclass.
    """
    _MODELS.register(name, cls)


def model_class(name: str) -> type[LGMDModel]:
    """The class behind a model name or a "package.module:Class" spec.

    Raises:
        ValueError: an unknown name (naming the valid ones), or a spec whose module does
            not import, that has no such class, or whose class is not an `LGMDModel`.
    """
    return _MODELS.get(name)


def origin(name: str) -> str:
    """Where model `name` comes from: "built-in", "registered", "entry point of DIST"
    or "spec"."""
    return _MODELS.origin(name)


def presets_of(name: str) -> dict[str, dict[str, Any]]:
    """Every preset of model `name`, its default first: the class's own, then the
    calibrated ones of the data files, the user's on top of the shipped ones
    (`lgmd_sim.models.presets`)."""
    from lgmd_sim.models.presets import data_presets

    cls = model_class(name)
    return {**cls.presets, **data_presets(name, cls.presets)}


def make(
    name: str, *, preset: str | None = None, n_streams: int | None = None, **params: Any
) -> LGMDModel:
    """Build model `name` from a preset (the model's first by default) and overrides.

    Args:
        name: one of `available()`, or a "package.module:Class" spec.
        preset: a named parameter set of that model (e.g. "paper" for `feedback`), with
            optional front-end suffixes (`FRONT_END_SUFFIXES`: "published+image").
        n_streams: None for one stream; N to run N independent streams at once.
        **params: parameter overrides, each checked (see the model's ``Params``).
    """
    cls = model_class(name)
    base, fronts = _split_preset(name, preset)
    known = cls.Params.names()
    unknown = sorted(set(params) - known)
    if unknown:
        raise ValueError(f"unknown parameter(s) {', '.join(unknown)} for model {name!r}; "
                         f"valid: {', '.join(sorted(known))}")
    clash = sorted(set(params) & set(fronts))
    if clash:
        raise ValueError(f"preset {preset!r} sets {', '.join(clash)} already")
    return run_hook(cls, "__init__", cls, cls.Params(**{**presets_of(name)[base], **fronts,
                                                          **params}), n_streams=n_streams)


def parse_spec(token: str) -> tuple[str, str]:
    """A detector named "model" (its default preset) or "model/preset", either optionally
    followed by front ends ("+image", "+gain"...): (model, preset), the preset written
    out in full with its front ends in a fixed order ("lgmd1+gain+image" ->
    ("lgmd1", "published+image+gain")), ready for ``make(model, preset=preset)``. The
    model may be a "package.module:Class" spec: "mypkg.looming:Mine/fast+image" ->
    ("mypkg.looming:Mine", "fast+image").

    Raises:
        ValueError: unknown model, preset or front end, naming the valid ones.
    """
    head, *suffixes = token.strip().split("+")
    name, _, preset = head.partition("/")
    model_class(name)
    preset = "+".join([preset or next(iter(presets_of(name))), *suffixes])
    _split_preset(name, preset)
    base, *given = preset.split("+")
    return name, "+".join([base, *(s for s in FRONT_END_SUFFIXES if s in given)])


def _split_preset(name: str, preset: str | None) -> tuple[str, dict[str, Any]]:
    """A preset with its front-end suffixes: the preset's name and the suffixes'
    parameters. None is the model's default preset."""
    own = presets_of(name)
    base, *suffixes = (next(iter(own)) if preset is None else preset).split("+")
    if base not in own:
        raise ValueError(f"unknown preset {base!r} for model {name!r}; available: "
                         f"{', '.join(own)}")
    unknown = [s for s in suffixes if s not in FRONT_END_SUFFIXES]
    if unknown:
        raise ValueError(f"unknown front end(s) {', '.join(map(repr, unknown))}; available: "
                         f"{', '.join('+' + s for s in FRONT_END_SUFFIXES)}")
    sources = [s for s in suffixes if "stabilize" in FRONT_END_SUFFIXES[s]]
    if len(sources) > 1 or len(set(suffixes)) < len(suffixes):
        raise ValueError(f"preset {preset!r}: at most one of +pose, +imu, +image, and "
                         "each front end once")
    params: dict[str, Any] = {}
    for s in suffixes:
        params.update(FRONT_END_SUFFIXES[s])
    return base, params
