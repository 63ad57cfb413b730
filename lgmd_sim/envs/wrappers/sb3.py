"""`VecLGMDObservation`: `LGMDObservation` for a stable-baselines3 VecEnv (the 'rl' extra).

>>> from stable_baselines3.common.vec_env import SubprocVecEnv
>>> venv = VecLGMDObservation(SubprocVecEnv([make_env] * 4), keep_frame=False)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lgmd_sim.core.extras import require
from lgmd_sim.envs.wrappers.frames import frame_size_of
from lgmd_sim.envs.wrappers.lgmd import LGMDFeatures

__all__ = ["VecLGMDObservation"]

_vec_env = require("stable_baselines3.common.vec_env", "rl")


class VecLGMDObservation(_vec_env.VecEnvWrapper):
    """`LGMDObservation` for a stable-baselines3 VecEnv (DummyVecEnv, SubprocVecEnv), with
    one batched model per model name across its environments.

    Observations, ``infos`` (with ``terminal_observation``) and ``reset_infos`` are those
    of the VecEnv of N separately wrapped environments, bit for bit. SB3 resets an ended
    environment in the same step: the terminal observation comes from a copy of the
    models that continues the ended streams, then those streams restart on the reset
    observation. See `LGMDFeatures` for the keys, shapes and what the grid holds.

    Args:
        venv: a VecEnv of jitter environments (Dict observations with a uint8 "frame").
        model: a name of `lgmd_sim.models.available()` or a plug-in's
            "package.module:Class" spec, or a list of them.
        preset: the models' parameter set (None: each model's default).
        history: number of membrane potentials observed, newest last.
        grid: (rows, cols) of the S-layer summary, or None for none.
        grid_history: number of grids observed, newest last.
        memory: frames the per-column memory of the excitation lasts (0: none).
        keep_frame: keep the camera frame in the observation.
        **params: the models' parameter overrides.
    """

    def __init__(self, venv: Any, model: str | Sequence[str] = "feedback",
                 preset: str | None = None, history: int = 8,
                 grid: tuple[int, int] | None = (1, 3), grid_history: int = 1,
                 memory: int = 0, keep_frame: bool = True, **params: Any) -> None:
        features = LGMDFeatures(venv.num_envs, model, preset=preset, history=history,
                                grid=grid, grid_history=grid_history, memory=memory,
                                keep_frame=keep_frame,
                                frame_size=frame_size_of(venv.observation_space), **params)
        super().__init__(venv, observation_space=features.observation_space(
            venv.observation_space))
        self.features = features

    def reset(self) -> dict[str, np.ndarray]:
        obs = self.venv.reset()
        self.features.step(obs["frame"], np.ones(self.num_envs, bool), self.venv.reset_infos)
        self.reset_infos = [{**r, **self.features.info(i)}
                            for i, r in enumerate(self.venv.reset_infos)]
        return self.features.observation(obs)

    def step_wait(self) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, list[dict]]:
        obs, rewards, dones, infos = self.venv.step_wait()
        ended = np.flatnonzero(dones)
        last = self.features
        if ended.size:
            frames = obs["frame"].copy()
            for i in ended:
                frames[i] = infos[i]["terminal_observation"]["frame"]
            last = self.features.ahead(frames, infos)
            for i in ended:
                infos[i]["terminal_observation"] = last.observation(
                    infos[i]["terminal_observation"], i)
        # an ended environment's observation is its reset one, with its reset info
        self.features.step(obs["frame"], dones, [self.venv.reset_infos[i] if dones[i] else info
                                                 for i, info in enumerate(infos)])
        for i, info in enumerate(infos):
            info.update((last if dones[i] else self.features).info(i))
        for i in ended:
            self.reset_infos[i] = {**self.venv.reset_infos[i], **self.features.info(i)}
        return self.features.observation(obs), rewards, dones, infos
