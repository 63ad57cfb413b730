"""Controllers: what drives the camera's carrier, frame by frame.

One small interface: ``reset()`` at the start of an episode, ``act(obs, info) -> action``
on every frame (the action for `JitterEnv.step`: (v, omega) in [-1, 1]). Each controller
documents what it reads of the observation and of ``info`` (the ground truth).

>>> from lgmd_sim.controllers import make, rollout
>>> for step in rollout(env, make("straight"), seed=0):
...     step.obs["frame"], step.info["threat_ttc"], step.action
"""

from __future__ import annotations

from typing import Any

from lgmd_sim.controllers.base import Controller, Step, rollout
from lgmd_sim.controllers.straight import Straight, StraightParams
from lgmd_sim.registry import lookup

__all__ = ["Controller", "Step", "Straight", "StraightParams", "available", "controller_class",
           "make", "rollout"]

# name -> "module:class", imported on first use
_REGISTRY: dict[str, str] = {
    "straight": "lgmd_sim.controllers.straight:Straight",
    "reactive": "lgmd_sim.controllers.avoid:ReactiveAvoid",
    "oracle": "lgmd_sim.controllers.avoid:Oracle",
    "policy": "lgmd_sim.controllers.policy:Policy",  # a trained policy (the 'rl' extra)
}


def available() -> list[str]:
    """The controller names `make` accepts."""
    return list(_REGISTRY)


def controller_class(name: str) -> type[Controller]:
    """The class behind a controller name."""
    return lookup(_REGISTRY, name, "controller")


def make(name: str, **params: Any) -> Controller:
    """Build controller `name` with parameter overrides (each checked)."""
    return controller_class(name)(**params)
