"""The training VecEnv of a policy, built from its `PolicyConfig`.

`make_vec_env` builds the training VecEnv (SubprocVecEnv workers, or one in-process
DummyVecEnv) whose observations are those of `lgmd_sim.policies.observe`'d environments
(what the `lgmd_sim.controllers.Policy` controller acts on), bit for bit: for "features"
the LGMD models run batched across the environments in this process
(`VecLGMDObservation`, identical to `LGMDObservation` per environment), for "pixels" and
"privileged" each worker runs `observe` (`PixelObservation`, `PrivilegedObservation`).

Observation normalisation (`VecNormalize`) sits on top during training; the policy folder
keeps its statistics and the controller applies them frozen (`Normalizer`).

Reward shaping (`parse_reward`, the key ``reward = ["KEY=VALUE"]`` of ``lgmd-sim train
--config``) changes the training environments' reward parameters only: validation,
``lgmd-sim bench closed-loop --policies`` and the benchmark keep the environment's own
reward and success.
"""

from __future__ import annotations

import copy
import functools
import time
from collections.abc import Iterable, Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.observe import base_env, observe

__all__ = ["REWARD_KEYS", "VecEnvs", "bare_speed", "make_vec_env", "normalized",
           "normalized_keys", "parse_reward"]

#: The environment parameters the ``reward`` key may change (`lgmd_sim.envs.params.EnvParams`).
REWARD_KEYS = ("progress_reward", "collision_penalty", "effort_penalty", "goal_bonus",
               "time_penalty", "proximity_penalty")


def parse_reward(items: Iterable[str]) -> dict[str, float]:
    """``KEY=VALUE`` reward parameters of the training environments, KEY one of
    `REWARD_KEYS`, VALUE a number the parameter's own check accepts.

    Raises:
        ValueError: not KEY=VALUE, another key, a value that is not a number or that the
            parameter refuses (one line naming it).
    """
    from lgmd_sim.envs.params import EnvParams

    out: dict[str, float] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or key not in REWARD_KEYS:
            raise ValueError(f"reward {item!r}: not KEY=VALUE with KEY one of "
                             f"{', '.join(REWARD_KEYS)}")
        if key in out:
            raise ValueError(f"reward {key} is given twice")
        try:
            out[key] = float(text)
        except ValueError:
            raise ValueError(f"reward {item}: {text!r} is not a number") from None
        try:
            EnvParams(**{key: out[key]})
        except ValueError as exc:
            raise ValueError(f"reward {item}: {exc}") from None
    return out


def _worker_env(config: PolicyConfig, overrides: Mapping[str, Any]) -> gym.Env:
    """One environment of a training VecEnv (runs in the worker)."""
    import lgmd_sim  # noqa: F401  (registers the scenarios in a fresh worker)

    env = base_env(config, **overrides)
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


def make_vec_env(config: PolicyConfig, n_envs: int,
                 overrides: Mapping[str, Any] | None = None) -> VecEnvs:
    """`n_envs` environments of `config` as a stable-baselines3 VecEnv: SubprocVecEnv
    workers, or a DummyVecEnv in this process for one; `overrides` are environment
    parameters on top of the policy's (the training environments' reward shaping)."""
    from stable_baselines3.common import vec_env

    from lgmd_sim.envs.wrappers.sb3 import VecLGMDObservation

    fns = [functools.partial(_worker_env, config, dict(overrides or {}))] * n_envs
    base = vec_env.SubprocVecEnv(fns) if n_envs > 1 else vec_env.DummyVecEnv(fns)
    venv = base
    if config.obs == "features":
        venv = VecLGMDObservation(base, config.model, preset=config.preset,
                                  history=config.history, grid=config.grid,
                                  grid_history=config.grid_history, memory=config.memory,
                                  keep_frame=False)
    return VecEnvs(base, vec_env.VecMonitor(venv))


def bare_speed(envs: VecEnvs, env_id: str, steps: int = 100) -> float:
    """Steps per second (over all environments) of the workers' VecEnv alone, `steps` per
    environment driving straight at 0.6 m/s; raise ValueError on a reward that is not
    finite."""
    base = envs.base
    base.reset()
    actions = np.tile(np.array([0.6, 0.0], np.float32), (base.num_envs, 1))
    start = time.perf_counter()
    for step in range(steps):
        _, rewards, _, _ = base.step(actions)
        if not np.isfinite(rewards).all():
            raise ValueError(f"{env_id}: reward {rewards.tolist()} at step {step + 1} is not "
                             "finite: check the environment's reward parameters")
    return steps * base.num_envs / (time.perf_counter() - start)


def normalized_keys(venv: Any, obs: str) -> list[str]:
    """The observation keys `VecNormalize` normalises: all, but a pixel policy's frames,
    which go to the CNN as they are (scaled to [0, 1] by the policy)."""
    return [k for k in venv.observation_space.spaces if not (obs == "pixels" and k == "frame")]


def normalized(venv: Any, obs: str, algo: str, kwargs: Mapping[str, Any],
               like: Any | None = None) -> Any:
    """`venv` in a training VecNormalize (PPO's rewards too, SAC's as they are) with the
    algorithm's discount (`kwargs`), starting from the statistics of `like` (the
    environments of the curriculum stage before), if given."""
    from stable_baselines3.common.vec_env import VecNormalize

    out = VecNormalize(venv, norm_obs_keys=normalized_keys(venv, obs),
                       gamma=kwargs.get("gamma", 0.99), norm_reward=algo == "ppo")
    if like is not None:
        out.obs_rms, out.ret_rms = copy.deepcopy(like.obs_rms), copy.deepcopy(like.ret_rms)
    return out
