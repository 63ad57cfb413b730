"""The controller interface and `rollout`, the one episode loop every tool uses."""

from __future__ import annotations

import itertools
from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from lgmd_sim.core.params import CheckedParams


class Controller(ABC):
    """Chooses the carrier's action from what it sees and, for oracles, the ground truth.

    Subclasses declare their parameters as a `CheckedParams` (``Params``) and take them as
    keyword overrides, as models do.
    """

    Params: ClassVar[type[CheckedParams]]
    #: Whether the controller is driven by an LGMD model (its ``model`` and ``preset``).
    uses_model: ClassVar[bool] = False
    #: Whether the controller's detector (LGMD alarm, ground-truth trigger) fired on the
    #: last frame it acted on; False for controllers without one.
    alarm: bool = False
    #: Whether the last action was an avoidance manoeuvre (braking and turning away from
    #: a threat); None where the controller cannot tell (a trained policy turns away
    #: without naming it a manoeuvre), so that no one reports it as never manoeuvring.
    manoeuvring: bool | None = None

    def __init__(self, **params: Any) -> None:
        self.params = self.resolve(**params)
        self.reset()

    @classmethod
    def resolve(cls, **params: Any) -> CheckedParams:
        """The parameters a controller built with overrides `params` runs with, checked,
        without building it (or its model)."""
        return cls.Params(**params)

    def reset(self) -> None:  # noqa: B027  (optional hook: stateless controllers keep it)
        """Start a new episode (forget any state)."""

    def wrap_env(self, env: gym.Env) -> gym.Env:
        """The environment as this controller observes it (a trained policy adds the
        wrappers it was trained with); most controllers take it as it is."""
        return env

    @abstractmethod
    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        """The action, (v, omega) in [-1, 1], for the frame just observed."""


@dataclass(frozen=True)
class Step:
    """One frame of an episode and the action chosen on seeing it.

    Attributes:
        index: the frame index (0 is the reset frame).
        obs, info: what `reset` or `step` returned for this frame.
        action: the controller's action for this frame; None on the last frame.
        reward: the reward of the step that led to this frame (0 on frame 0).
        terminated, truncated: whether the episode ended at this frame.
    """

    index: int
    obs: dict[str, np.ndarray]
    info: dict[str, Any]
    action: np.ndarray | None
    reward: float
    terminated: bool
    truncated: bool


def rollout(env: gym.Env, controller: Controller, seed: int | None = None) -> Iterator[Step]:
    """Yield every frame of one episode of `env` driven by `controller`, from the reset
    frame to the last (terminated or truncated)."""
    obs, info = env.reset(seed=seed)
    controller.reset()
    reward, terminated, truncated = 0.0, False, False
    for index in itertools.count():
        done = terminated or truncated
        action = None if done else np.asarray(controller.act(obs, info), np.float32)
        yield Step(index, obs, info, action, float(reward), terminated, truncated)
        if done:
            return
        obs, reward, terminated, truncated, info = env.step(action)
