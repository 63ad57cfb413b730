"""The training VecEnv of a policy, built from its `PolicyConfig`.

`make_vec_env` builds the training VecEnv (SubprocVecEnv workers, or one in-process
DummyVecEnv) whose observations are those of `lgmd_sim.policies.observe`'d environments
(what the `lgmd_sim.controllers.Policy` controller acts on), bit for bit: for "features"
the LGMD models run batched across the environments in this process
(`VecLGMDObservation`, identical to `LGMDObservation` per environment), for "pixels" and
"privileged" each worker runs `observe` (`PixelObservation`, `PrivilegedObservation`).

Observation normalisation (`VecNormalize`) sits on top during training; the policy folder
keeps its statistics and the controller applies them frozen (`Normalizer`).
"""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym

from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.observe import base_env, observe

__all__ = ["VecEnvs", "make_vec_env"]


def _worker_env(config: PolicyConfig) -> gym.Env:
    """One environment of a training VecEnv (runs in the worker)."""
    import lgmd_sim  # noqa: F401  (registers the scenarios in a fresh worker)

    env = base_env(config)
    # features: the LGMD models run batched over the workers' frames, in the main process;
    # privileged: in the worker, whose reset gives the info a VecEnv's reset does not
    return env if config.obs == "features" else observe(env, config)


class VecEnvs:
    """The layers of a training VecEnv: ``base`` (the workers; its ``reset_infos`` hold
    each episode's first ground truth), ``venv`` (what the algorithm steps: observations
    as `observe` gives them, episode statistics from ``VecMonitor``)."""

    def __init__(self, base: Any, venv: Any) -> None:
        self.base, self.venv = base, venv

    def close(self) -> None:
        self.venv.close()


def make_vec_env(config: PolicyConfig, n_envs: int) -> VecEnvs:
    """`n_envs` environments of `config` as a stable-baselines3 VecEnv: SubprocVecEnv
    workers, or a DummyVecEnv in this process for one."""
    from stable_baselines3.common import vec_env

    from lgmd_sim.envs.wrappers.sb3 import VecLGMDObservation

    fns = [functools.partial(_worker_env, config)] * n_envs
    base = vec_env.SubprocVecEnv(fns) if n_envs > 1 else vec_env.DummyVecEnv(fns)
    venv = base
    if config.obs == "features":
        venv = VecLGMDObservation(base, config.model, preset=config.preset,
                                  history=config.history, grid=config.grid, keep_frame=False)
    return VecEnvs(base, vec_env.VecMonitor(venv))
