"""What a policy observes: one Gymnasium environment wrapped as the policy of a
`lgmd_sim.policies.config.PolicyConfig` sees it (before normalisation).

`observe` is the pipeline both sides share: the `lgmd_sim.controllers.Policy` controller
acts on it in the benchmark, and training (`lgmd_sim.training.envs.make_vec_env`) builds
VecEnvs whose observations are those of `observe`'d environments, bit for bit. For
"features" that is the LGMD wrapper's compact features; for "pixels", `PixelObservation`;
for "privileged", `PrivilegedObservation` (the threat's ground truth, read from ``info``:
no frames, so it acts on a rendering environment as on the frameless one it trained in).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

from lgmd_sim.core.frames import to_grey
from lgmd_sim.core.params import int_in_range, tuple_of
from lgmd_sim.envs.wrappers import LGMDObservation, PrivilegedObservation
from lgmd_sim.envs.wrappers.frames import check_frame_space
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.world.params import MAX_SIDE

__all__ = ["MAX_STACK", "PixelObservation", "base_env", "observe"]

#: The most frames `PixelObservation` stacks: half a second at 30 fps, four times what
#: lgmd-sim train's pixel policies stack. 16 of the largest frames (`MAX_SIDE` each way)
#: hold 240 MB; a policy.json asking for more would exhaust the memory before any use.
MAX_STACK = 16


class PixelObservation(gym.ObservationWrapper):
    """The last `stack` camera frames, grey and shrunk to `size`, in place of the frame.

    ``obs["frame"]`` becomes uint8 (stack, H, W), oldest first (channels first, as
    stable-baselines3's CNN policies take it); at a reset every slot holds the first frame,
    so that a policy sees no motion that did not happen. Frames are shrunk with area
    averaging (OpenCV's INTER_AREA), which keeps thin obstacles visible.

    Args:
        env: a jitter environment (a Dict observation with a uint8 "frame").
        size: (height, width) of the observed frames, each 1 to `MAX_SIDE`.
        stack: number of frames observed, 1 to `MAX_STACK`.

    Raises:
        ValueError: a size or stack out of those bounds, before anything is allocated.
    """

    def __init__(self, env: gym.Env, size: tuple[int, int] = (60, 80), stack: int = 4) -> None:
        for name, value, check in (("size", size, tuple_of(int_in_range(1, MAX_SIDE), 2)),
                                   ("stack", stack, int_in_range(1, MAX_STACK))):
            if (error := check(value)) is not None:
                raise ValueError(f"{name} {error}, got {value!r}")
        super().__init__(env)
        check_frame_space(env.observation_space)
        self.size, self.stack = (int(size[0]), int(size[1])), int(stack)
        self._frames: deque[np.ndarray] = deque(maxlen=self.stack)
        self.observation_space = spaces.Dict({
            **env.observation_space.spaces,
            "frame": spaces.Box(0, 255, (self.stack, *self.size), np.uint8)})

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self._frames.clear()
        return super().reset(seed=seed, options=options)

    def observation(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        h, w = self.size
        small = cv2.resize(to_grey(observation["frame"]), (w, h), interpolation=cv2.INTER_AREA)
        if not self._frames:
            self._frames.extend([small] * self.stack)
        self._frames.append(small)
        return {**observation, "frame": np.stack(self._frames)}


def base_env(config: PolicyConfig, jitter: float | None = None, **overrides: Any) -> gym.Env:
    """The environment of `config` (at its training jitter unless `jitter` is given, with
    other environment parameters `overrides`); frameless for "privileged", which reads no
    frame: it steps at the physics' speed."""
    frame = {"frame": "none"} if config.obs == "privileged" else {}
    return gym.make(config.env_id, **{
        "jitter": config.jitter if jitter is None else jitter,
        "resolution": config.resolution, **frame, **overrides})


def observe(env: gym.Env, config: PolicyConfig) -> gym.Env:
    """`env` as the policy of `config` observes it (before normalisation)."""
    if config.obs == "features":
        return LGMDObservation(env, config.model, preset=config.preset,
                               history=config.history, grid=config.grid,
                               grid_history=config.grid_history, memory=config.memory,
                               keep_frame=False)
    if config.obs == "privileged":
        return PrivilegedObservation(env)
    return PixelObservation(env, config.frame_size, config.frame_stack)
