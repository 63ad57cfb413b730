"""Wrappers for jitter environments: an LGMD model watching the camera, frames alone.

>>> env = LGMDObservation(gym.make("lgmd_sim/RoughTerrainObstacles-v0"), model="feedback")
>>> obs, info = env.reset(seed=0)     # obs["lgmd"]: the membrane potential, in [0.5, 1)
>>> env = FrameObservation(gym.make("lgmd_sim/PassBy-v0"))   # obs: the frame only
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces


class LGMDObservation(gym.ObservationWrapper):
    """Run an LGMD model (`lgmd_sim.models`) on every camera frame.

    Adds ``"lgmd"`` (float32 (1,): the membrane potential) to the observation and
    ``lgmd_potential`` and ``lgmd_alarm`` (potential above the model's threshold) to
    ``info``. The model starts a new stream at every reset.

    Args:
        env: a jitter environment (Dict observation with a ``"frame"``).
        model: a name of `lgmd_sim.models.available()`.
        **params: the model's parameter overrides (and ``preset``).
    """

    def __init__(self, env: gym.Env, model: str = "feedback", **params: Any) -> None:
        from lgmd_sim import models

        super().__init__(env)
        self.model = models.make(model, **params)
        self.observation_space = spaces.Dict({
            **env.observation_space.spaces,
            "lgmd": spaces.Box(0.0, 1.0, (1,), np.float32),
        })
        self._last = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self.model.reset()
        obs, info = super().reset(seed=seed, options=options)
        return obs, self._annotate(info)

    def step(self, action):
        obs, reward, terminated, truncated, info = super().step(action)
        return obs, reward, terminated, truncated, self._annotate(info)

    def observation(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        self._last = self.model.step(observation["frame"])
        return {**observation, "lgmd": np.array([self._last.potential], np.float32)}

    def _annotate(self, info: dict[str, Any]) -> dict[str, Any]:
        return {**info, "lgmd_potential": float(self._last.potential),
                "lgmd_alarm": bool(self._last.alarm)}


class FrameObservation(gym.ObservationWrapper):
    """Observe the camera frame alone (a Box), e.g. for image-only policies."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.observation_space = env.observation_space["frame"]

    def observation(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        return observation["frame"]
