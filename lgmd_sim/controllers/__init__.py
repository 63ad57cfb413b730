"""Controllers: what drives the camera's carrier, frame by frame.

One small interface: ``reset()`` at the start of an episode, ``act(obs, info) -> action``
on every frame (the action for `JitterEnv.step`: (v, omega) in [-1, 1]). Each controller
documents what it reads of the observation and of ``info`` (the ground truth).

>>> from lgmd_sim.controllers import make, rollout
>>> for step in rollout(env, make("straight"), seed=0):
...     step.obs["frame"], step.info["threat_ttc"], step.action

A controller of your own (a `Controller` subclass) joins by a "package.module:Class" spec
wherever a controller name goes (``make("mypkg.drive:Mine")``, ``bench closed-loop
--controllers mypkg.drive:Mine``), or by a name: ``register("mine", Mine)``.
"""

from __future__ import annotations

from typing import Any

from lgmd_sim.controllers.base import Controller, Step, rollout
from lgmd_sim.controllers.straight import Straight, StraightParams
from lgmd_sim.core.registry import Registry

__all__ = ["Controller", "Step", "Straight", "StraightParams", "available", "controller_class",
           "make", "register", "rollout"]

# the built-ins as "module:class", imported on first use
_CONTROLLERS = Registry("controller", Controller, {
    "straight": "lgmd_sim.controllers.straight:Straight",
    "reactive": "lgmd_sim.controllers.avoid:ReactiveAvoid",
    "oracle": "lgmd_sim.controllers.avoid:Oracle",
    # the Oracle on what the camera sees only (lgmd_sim.world.view)
    "view-oracle": "lgmd_sim.controllers.avoid:ViewOracle",
    "steer": "lgmd_sim.controllers.steer:Steer",  # the Oracle's inputs, no memory
    "loom-steer": "lgmd_sim.controllers.loom:LoomSteer",  # steered by two LGMDs' potentials
    "policy": "lgmd_sim.controllers.policy:Policy",  # a trained policy (the 'rl' extra)
})


def available() -> list[str]:
    """The controller names `make` accepts: the built-ins, then those `register`ed. Any
    "package.module:Class" spec of a `Controller` is accepted as well."""
    return _CONTROLLERS.names()


def register(name: str, cls: type[Controller] | str) -> None:
    """Make controller `cls` (a `Controller` subclass, or a "package.module:Class" string,
    imported on first use) available as `name`, for this process; ValueError for a name
    taken or a class that is not a `Controller`."""
    _CONTROLLERS.register(name, cls)


def controller_class(name: str) -> type[Controller]:
    """The class behind a controller name or a "package.module:Class" spec; a one-line
    ValueError for an unknown name or a spec that names no `Controller`."""
    return _CONTROLLERS.get(name)


def make(name: str, **params: Any) -> Controller:
    """Build controller `name` (a name or a spec) with parameter overrides (each checked)."""
    return controller_class(name)(**params)
