"""The LGMD model family behind one interface, chosen by name.

>>> from lgmd_sim import models
>>> models.available()
['feedback', 'lgmd1', 'lgmd2', 'f_on', 'f_off']
>>> m = models.make("feedback")            # the paper's feedback LGMD, preset "paper"
>>> out = m.step(frame)                     # out.potential in [0.5, 1), out.alarm
>>> batch = models.make("lgmd2", n_streams=8)   # 8 independent streams, frames (8, H, W)
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from lgmd_sim.models.base import LGMDModel, LGMDOutput, ModelParams

__all__ = ["LGMDModel", "LGMDOutput", "ModelParams", "available", "make", "model_class",
           "parse_spec"]

# name -> "module:class"; imported on first use so that `available()` stays cheap.
_REGISTRY: dict[str, str] = {
    "feedback": "lgmd_sim.models.feedback:FeedbackLGMD",
    "lgmd1": "lgmd_sim.models.lgmd1:LGMD1",
    "lgmd2": "lgmd_sim.models.lgmd2:LGMD2",
    "f_on": "lgmd_sim.models.ffi:FOnLGMD",
    "f_off": "lgmd_sim.models.ffi:FOffLGMD",
}


_DATA_PRESETS_JOINED: set[str] = set()


def available() -> list[str]:
    """The model names `make` accepts."""
    return list(_REGISTRY)


def model_class(name: str) -> type[LGMDModel]:
    """The class behind a model name."""
    if name not in _REGISTRY:
        raise ValueError(f"unknown model {name!r}; available: {', '.join(_REGISTRY)}")
    module, cls_name = _REGISTRY[name].split(":")
    cls = getattr(import_module(module), cls_name)
    if name not in _DATA_PRESETS_JOINED:
        # calibrated presets live in a data file (lgmd_sim.models.presets): they join the
        # class's own presets on first use
        from lgmd_sim.models.presets import data_presets

        cls.presets = {**cls.presets, **data_presets(name, cls.presets)}
        _DATA_PRESETS_JOINED.add(name)
    return cls


def make(
    name: str, *, preset: str | None = None, n_streams: int | None = None, **params: Any
) -> LGMDModel:
    """Build model `name` from a preset (the model's first by default) and overrides.

    Args:
        name: one of `available()`.
        preset: a named parameter set of that model (e.g. "paper" for `feedback`).
        n_streams: None for one stream; N to run N independent streams at once.
        **params: parameter overrides, each checked (see the model's ``Params``).
    """
    cls = model_class(name)
    preset = next(iter(cls.presets)) if preset is None else preset
    if preset not in cls.presets:
        raise ValueError(f"unknown preset {preset!r} for model {name!r}; available: "
                         f"{', '.join(cls.presets)}")
    known = cls.Params.names()
    unknown = sorted(set(params) - known)
    if unknown:
        raise ValueError(f"unknown parameter(s) {', '.join(unknown)} for model {name!r}; "
                         f"valid: {', '.join(sorted(known))}")
    return cls(cls.Params(**{**cls.presets[preset], **params}), n_streams=n_streams)


def parse_spec(token: str) -> tuple[str, str]:
    """A detector named "model" (its default preset) or "model/preset": (model, preset).

    Raises:
        ValueError: unknown model or preset, naming the valid ones.
    """
    name, _, preset = token.strip().partition("/")
    cls = model_class(name)
    preset = preset or next(iter(cls.presets))
    if preset not in cls.presets:
        raise ValueError(f"unknown preset {preset!r} for model {name!r}; available: "
                         f"{', '.join(cls.presets)}")
    return name, preset
