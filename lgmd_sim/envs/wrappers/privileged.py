"""`PrivilegedObservation`: the ground truth the Oracle reads, as an observation.

A privileged policy sees what `lgmd_sim.controllers.Oracle` triggers on (the threat's
distance, bearing and time to collision, from ``info``) beside the proprioception and
the goal, instead of frames: meant as the upper bound of what the RL pipeline reaches on
the task, and a teacher for students that see only an LGMD's features.

>>> env = PrivilegedObservation(gym.make("lgmd_sim/RoughTerrainObstacles-v0"))
>>> obs, info = env.reset(seed=0)   # obs: proprio, goal, threat (no frame)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

__all__ = ["SPEED_RANGE", "THREAT_RANGE", "TTC_RANGE", "PrivilegedObservation",
           "threat_features"]

# The ranges reach far beyond the Oracle's trigger zone (horizon 1 s, clearance 0.25 m:
# lgmd_sim.envs.zone.TriggerZone), so clipping never changes what the Oracle
# would decide, while "no threat" and a threat not closing (distance or time to collision
# inf) read as far and never: finite values that observation normalisation can average.
#: Threat distance observed (m); negative within MuJoCo's penetration depth.
THREAT_RANGE = 10.0
#: Time to collision observed (s).
TTC_RANGE = 10.0
#: Closing speed observed (m/s): ten times the robot's default max_speed (1 m/s), five
#: times the default mover's (2 m/s).
SPEED_RANGE = 10.0


def threat_features(info: Mapping[str, Any]) -> np.ndarray:
    """float32 (5,): the threat's distance (clipped to +-`THREAT_RANGE`), the sine and
    cosine of its bearing (radians, positive to the left), its time to collision (up to
    `TTC_RANGE`) and closing speed (clipped to +-`SPEED_RANGE`), from a jitter
    environment's ``info``."""
    bearing = float(info["threat_bearing"])
    return np.array([
        np.clip(float(info["threat_distance"]), -THREAT_RANGE, THREAT_RANGE),
        np.sin(bearing), np.cos(bearing),
        min(float(info["threat_ttc"]), TTC_RANGE),
        np.clip(float(info["threat_closing_speed"]), -SPEED_RANGE, SPEED_RANGE),
    ], np.float32)


class PrivilegedObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """A jitter environment's observation without the frame, with ``threat``
    (`threat_features` of the step's ``info``) added: ``proprio``, ``goal`` (where the
    scenario has one) and ``threat``; ``info`` passes unchanged.

    A Wrapper, not an ObservationWrapper, because the features come from ``info``. It
    drops the frame where there is one, so a policy trained on a frameless environment
    acts on a rendering one (the benchmark's) as it was trained.

    Args:
        env: a jitter environment (its ``info`` holds the threat's ground truth).
    """

    def __init__(self, env: gym.Env) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)
        if not isinstance(env.observation_space, spaces.Dict):
            raise ValueError("env: needs a Dict observation space (a jitter environment's), "
                             f"got {env.observation_space}")
        low = np.array([-THREAT_RANGE, -1, -1, 0, -SPEED_RANGE], np.float32)
        high = np.array([THREAT_RANGE, 1, 1, TTC_RANGE, SPEED_RANGE], np.float32)
        self.observation_space = spaces.Dict({
            **{k: s for k, s in env.observation_space.spaces.items() if k != "frame"},
            "threat": spaces.Box(low, high, dtype=np.float32)})

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        return self.observation_of(obs, info), info

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool,
                                                 dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self.observation_of(obs, info), reward, terminated, truncated, info

    @staticmethod
    def observation_of(obs: Mapping[str, np.ndarray], info: Mapping[str, Any]
                       ) -> dict[str, np.ndarray]:
        """The privileged observation of a jitter environment's `obs` and `info`."""
        return {**{k: v for k, v in obs.items() if k != "frame"},
                "threat": threat_features(info)}
