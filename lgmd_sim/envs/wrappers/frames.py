"""Wrappers on the camera frame: seeded noise (the paper's noisy streams), the frame alone.

>>> env = NoiseObservation(gym.make("lgmd_sim/PassBy-v0"), "gaussian:0.005,saltpepper:0.005")
>>> env = FrameObservation(gym.make("lgmd_sim/PassBy-v0"))   # obs: the frame only
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from lgmd_sim import noise as noise_lib


def check_frame_space(space: gym.Space) -> None:
    """Raise ValueError unless `space` is a Dict observation space with a uint8 "frame"."""
    frame = space.spaces.get("frame") if isinstance(space, spaces.Dict) else None
    if not (isinstance(frame, spaces.Box) and frame.dtype == np.uint8):
        raise ValueError("env: needs a Dict observation space with a uint8 'frame' Box "
                         f"(a jitter environment's), got {space}")


class NoiseObservation(gym.Wrapper):
    """Corrupt the camera frame with seeded noise (`lgmd_sim.noise`), as the paper's dataset (d).

    ``obs["frame"]`` becomes ``noise.apply(frame, noises, episode_seed, index)``, with the
    index counting the episode's frames from 0 at the reset. The episode seed is the
    reset's seed; a reset without one draws it from a generator seeded by the last seed
    given (from fresh entropy before any), so episodes differ and a seeded run repeats
    exactly. The generator is the wrapper's own: the wrapped environment's episodes are
    the same with and without the noise. RGB frames get the noise in each channel, as
    MATLAB's ``imnoise`` gives it to a colour image.

    To have an LGMD see the noisy frames, put this inside `LGMDObservation`:
    ``LGMDObservation(NoiseObservation(env, "gaussian:0.005"))``.

    Args:
        env: an environment with a Dict observation holding a uint8 ``"frame"``.
        noise: "kind:level,..." (`lgmd_sim.noise.parse`: ``gaussian:V``, variance V on the
            [0, 1] scale, the paper's 0.001 to 0.009; ``saltpepper:D``, density D, the
            paper's 0.001 to 0.009; ``shake:L``, extra rotation, translation and
            brightness gain at level L), or a list of `lgmd_sim.noise.Noise`, applied in
            order.
    """

    def __init__(self, env: gym.Env, noise: str | Sequence[noise_lib.Noise]) -> None:
        super().__init__(env)
        check_frame_space(env.observation_space)
        if not isinstance(noise, str) and not (
            isinstance(noise, Sequence) and all(isinstance(n, noise_lib.Noise) for n in noise)
        ):
            raise ValueError("noise must be a spec such as 'gaussian:0.005' or a list of "
                             f"lgmd_sim.noise.Noise, got {noise!r}")
        self.noises = noise_lib.parse(noise)
        self._seeds: np.random.Generator | None = None
        self._seed = 0
        self._index = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        if seed is not None or self._seeds is None:
            self._seeds = np.random.default_rng(seed)
        self._seed = int(seed) if seed is not None else int(self._seeds.integers(2**63))
        self._index = 0
        return self._corrupt(obs), info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], Any, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._index += 1
        return self._corrupt(obs), reward, terminated, truncated, info

    def _corrupt(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        frame = obs["frame"]
        noisy = noise_lib.apply(frame, self.noises, self._seed, self._index)
        # reshape: OpenCV's warp (shake) returns a grey (H, W, 1) frame as (H, W)
        return {**obs, "frame": noisy.reshape(frame.shape)}


class FrameObservation(gym.ObservationWrapper):
    """Observe the camera frame alone (a Box), e.g. for image-only policies."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        check_frame_space(env.observation_space)
        self.observation_space = env.observation_space["frame"]

    def observation(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        return observation["frame"]
