"""Gymnasium environments of the jitter world, the scenario catalogue and wrappers.

>>> import gymnasium as gym, lgmd_sim
>>> env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", jitter=1.0, resolution="rl")
>>> obs, info = env.reset(seed=0)      # obs: {"frame", "proprio", "goal"}; info: ground truth
>>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Scenarios of your own: ``register_catalogue("my_envs/")`` (or the ``LGMD_SIM_ENVS``
environment variable) registers every TOML file of a folder, as envs/ does.

`JitterEnv` (and MuJoCo) are imported on first use; the catalogue is not.
"""

from typing import Any

from lgmd_sim.envs.catalogue import register_all, register_catalogue, scenario, scenarios

__all__ = ["JitterEnv", "register_all", "register_catalogue", "scenario", "scenarios"]


def __getattr__(name: str) -> Any:
    if name == "JitterEnv":
        from lgmd_sim.envs.jitter_env import JitterEnv

        return JitterEnv
    raise AttributeError(f"module 'lgmd_sim.envs' has no attribute {name!r}")
