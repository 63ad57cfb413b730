"""Wrappers on the camera frame: seeded noise (the paper's noisy streams), the frame alone,
the frame resized.

>>> env = NoiseObservation(gym.make("lgmd_sim/PassBy-v0"), "gaussian:0.005,saltpepper:0.005")
>>> env = FrameObservation(gym.make("lgmd_sim/PassBy-v0"))   # obs: the frame only
>>> env = ResizeFrame(gym.make("lgmd_sim/PassBy-v0"), (64, 64))  # obs["frame"]: 64 x 64
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

from lgmd_sim.signals import noise as noise_lib


def check_frame_space(space: gym.Space) -> None:
    """Raise a one-line ValueError unless `space` is a Dict observation space with a uint8
    "frame"; a Dict without one names the likely causes (``frame="none"``, or a wrapper)."""
    if isinstance(space, spaces.Dict) and "frame" not in space.spaces:
        raise ValueError("env: its observation has no 'frame' key (frame='none', or a wrapper "
                         "such as PrivilegedObservation dropped it), but the camera frames "
                         "are needed here: make it with frame='rgb' or 'grey'")
    frame = space.spaces.get("frame") if isinstance(space, spaces.Dict) else None
    if not (isinstance(frame, spaces.Box) and frame.dtype == np.uint8):
        got = (f"Dict with keys {', '.join(space.spaces)}" if isinstance(space, spaces.Dict)
               else type(space).__name__)  # a space's repr spans lines
        raise ValueError("env: needs a Dict observation space with a uint8 'frame' Box "
                         f"(a jitter environment's), got {got}")


def frame_size_of(space: gym.Space) -> tuple[int, int]:
    """(height, width) of the frames of a jitter environment's observation `space` (checked
    by `check_frame_space`)."""
    check_frame_space(space)
    height, width = space["frame"].shape[:2]
    return int(height), int(width)


class NoiseObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Corrupt the camera frame with seeded noise (`lgmd_sim.signals.noise`), as the paper's
    dataset (d).

    ``obs["frame"]`` becomes ``noise.apply(frame, noises, episode_seed, index)``, with the
    index counting the episode's frames from 0 at the reset. The episode seed is the
    reset's seed; a reset without one draws it from a generator seeded by the last seed
    given (from fresh entropy before any), so episodes differ and a seeded run repeats
    exactly. The generator is the wrapper's own: the wrapped environment's episodes are
    the same with and without the noise. RGB frames get the paper's noises in each
    channel, as MATLAB's ``imnoise`` gives them to a colour image (exposure is one gain
    for every channel; jpeg compresses the colour image).

    To have an LGMD see the noisy frames, put this inside `LGMDObservation`:
    ``LGMDObservation(NoiseObservation(env, "gaussian:0.005"))``.

    Args:
        env: an environment with a Dict observation holding a uint8 ``"frame"``.
        noise: "kind:level,..." (`lgmd_sim.signals.noise.parse`: ``gaussian:V``, variance V on the
            [0, 1] scale, the paper's 0.001 to 0.009; ``saltpepper:D``, density D, the
            paper's 0.001 to 0.009; ``shake:L``, extra rotation, translation and
            brightness gain at level L; a real camera's ``exposure:L``, ``sensor:L``,
            ``blur:L`` and ``jpeg:Q``), or a list of `lgmd_sim.signals.noise.Noise`, applied in
            order.
    """

    def __init__(self, env: gym.Env, noise: str | Sequence[noise_lib.Noise]) -> None:
        # recorded for env.spec, so that gym.make(env.spec) rebuilds the wrapper
        gym.utils.RecordConstructorArgs.__init__(self, noise=noise)
        gym.Wrapper.__init__(self, env)
        check_frame_space(env.observation_space)
        if not isinstance(noise, str) and not (
            isinstance(noise, Sequence) and all(isinstance(n, noise_lib.Noise) for n in noise)
        ):
            raise ValueError("noise must be a spec such as 'gaussian:0.005' or a list of "
                             f"lgmd_sim.signals.noise.Noise, got {noise!r}")
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


class FrameObservation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """Observe the camera frame alone (a Box), e.g. for image-only policies."""

    def __init__(self, env: gym.Env) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.ObservationWrapper.__init__(self, env)
        check_frame_space(env.observation_space)
        self.observation_space = env.observation_space["frame"]

    def observation(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        return observation["frame"]


class ResizeFrame(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """Resize the camera frame of the Dict observation, the other keys unchanged.

    Gymnasium's `ResizeObservation` takes a Box observation only; this does what it does
    (OpenCV's area interpolation, ``shape`` as (height, width)) to ``obs["frame"]``. Put it
    outside `LGMDObservation` to have the models watch the full frame and a policy see a
    small one; to render small in the first place, make the env with ``resolution=[h, w]``.

    Args:
        env: an environment with a Dict observation holding a uint8 ``"frame"``.
        shape: (height, width) of the resized frame, in pixels.
    """

    def __init__(self, env: gym.Env, shape: tuple[int, int]) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, shape=shape)
        gym.ObservationWrapper.__init__(self, env)
        check_frame_space(env.observation_space)
        if not (isinstance(shape, Sequence) and not isinstance(shape, str) and len(shape) == 2
                and all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v > 0
                        for v in shape)):
            raise ValueError(f"shape must be (height, width) of positive integers, got {shape!r}")
        self.shape = (int(shape[0]), int(shape[1]))
        frame = env.observation_space["frame"]
        self._frame_space = spaces.Box(0, 255, self.shape + frame.shape[2:], np.uint8)
        self.observation_space = spaces.Dict({**env.observation_space.spaces,
                                              "frame": self._frame_space})

    def observation(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        # cv2 takes (width, height) and drops the channel axis of a grey frame
        frame = cv2.resize(observation["frame"], self.shape[::-1], interpolation=cv2.INTER_AREA)
        return {**observation, "frame": frame.reshape(self._frame_space.shape)}
