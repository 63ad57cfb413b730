"""Wrappers for jitter environments: LGMD models watching the camera, noise, the frame alone,
the ground truth.

>>> from lgmd_sim.envs.wrappers import LGMDObservation, NoiseObservation
>>> env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="rl")
>>> env = LGMDObservation(NoiseObservation(env, "gaussian:0.005"), model=["feedback", "lgmd1"])
>>> obs, info = env.reset(seed=0)   # obs: frame, proprio, goal, lgmd_potential, lgmd_alarm,
...                                 # lgmd_grid; info["lgmd_potential"]["lgmd1"]

- `LGMDObservation`: one environment; `LGMDVectorObservation`: a Gymnasium vector
  environment; `VecLGMDObservation` (needs the 'rl' extra): a stable-baselines3 VecEnv.
  The vector versions run one batched model across the environments and give the same
  outputs as separately wrapped environments. `LGMDFeatures` documents the keys.
- `NoiseObservation`: seeded Gaussian, salt-and-pepper and shake noise on the frame.
- `FrameObservation`: the frame alone, as a Box.
- `ResizeFrame`: the frame resized, the other keys kept (Gymnasium's `ResizeObservation`
  takes a Box only).
- `PrivilegedObservation`: the ground truth the Oracle reads (the threat's distance,
  bearing, time to collision and closing speed) in place of the frame.

Every single-environment wrapper records its arguments
(`gymnasium.utils.RecordConstructorArgs`), so that
``gym.make(env.spec)`` rebuilds the wrapped environment and Gymnasium's ``check_env``
passes on it.
"""

from typing import Any

from lgmd_sim.envs.wrappers.frames import FrameObservation, NoiseObservation, ResizeFrame
from lgmd_sim.envs.wrappers.lgmd import (
    KEYS,
    LGMDFeatures,
    LGMDObservation,
    LGMDVectorObservation,
)
from lgmd_sim.envs.wrappers.privileged import PrivilegedObservation

__all__ = ["KEYS", "FrameObservation", "LGMDFeatures", "LGMDObservation",
           "LGMDVectorObservation", "NoiseObservation", "PrivilegedObservation", "ResizeFrame",
           "VecLGMDObservation"]


def __getattr__(name: str) -> Any:
    if name == "VecLGMDObservation":  # stable-baselines3 is optional (the 'rl' extra)
        from lgmd_sim.envs.wrappers.sb3 import VecLGMDObservation

        return VecLGMDObservation
    raise AttributeError(f"module 'lgmd_sim.envs.wrappers' has no attribute {name!r}")
