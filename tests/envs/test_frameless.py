"""Frameless environments (frame="none"): the same physics and truth, no rendering."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401 - registers the scenarios
from lgmd_sim.data.generate import GenerateConfig
from lgmd_sim.envs.wrappers import LGMDObservation

STEPS = 60


def make(**overrides) -> gym.Env:
    return gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", **overrides)


def run(frame: str) -> tuple[list, gym.Env]:
    """Reset, then STEPS seeded random actions (resetting after an episode's end), with
    the SSIM asked for."""
    env = make(frame=frame, ssim=True)
    actions = np.random.default_rng(0).uniform(-1, 1, (STEPS, 2))
    out = [env.reset(seed=3)]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        out.append((obs, info, reward, terminated, truncated))
        if terminated or truncated:
            out.append(env.reset())
    return out, env


def test_frame_none_keeps_physics_and_truth_bit_identical():
    grey, env_grey = run("grey")
    none, env_none = run("none")
    env_grey.close()
    env_none.close()
    assert len(grey) == len(none)
    for a, b in zip(grey, none, strict=True):
        (obs_a, info_a, *rest_a), (obs_b, info_b, *rest_b) = a, b
        assert rest_a == rest_b  # reward, terminated, truncated
        assert set(obs_a) - set(obs_b) == {"frame"}
        for key in obs_b:
            assert np.array_equal(obs_a[key], obs_b[key]), key
        assert info_a.keys() == info_b.keys()
        for key in info_a:
            if key == "ssim":
                assert math.isnan(info_b[key])
            else:
                assert np.array_equal(info_a[key], info_b[key]), key
    assert any(not math.isnan(step[1]["ssim"]) for step in grey)


def test_frame_none_observes_no_frame_and_opens_no_gl():
    steps, env = run("none")
    assert "frame" not in env.observation_space.spaces
    assert all("frame" not in step[0] for step in steps)
    assert env.observation_space.contains(steps[-1][0])
    assert env.unwrapped.world._renderer is None
    env.close()


def test_frame_none_render_rgb_array_renders_on_demand():
    rendering = make(frame="rgb")
    frameless = make(frame="none", render_mode="rgb_array")
    world = frameless.unwrapped.world
    for seed in (0, None):  # the second episode's terrain reaches a live renderer
        obs, _ = rendering.reset(seed=seed)
        frameless.reset(seed=seed)
        assert (world._renderer is None) == (seed == 0)  # made by the first render()
        assert np.array_equal(frameless.render(), obs["frame"])
        for _ in range(3):
            obs = rendering.step([0.5, 0.3])[0]
            frameless.step([0.5, 0.3])
        assert np.array_equal(frameless.render(), obs["frame"])
    rendering.close()
    frameless.close()


def test_lgmd_wrapper_refuses_a_frameless_env():
    env = make(frame="none")
    with pytest.raises(ValueError, match=r"has no 'frame' key \(frame='none'") as error:
        LGMDObservation(env)
    assert "\n" not in str(error.value)
    env.close()


def test_a_dataset_refuses_a_frameless_env_before_any_episode():
    with pytest.raises(ValueError, match="RoughTerrainObstacles: frame='none' renders no "
                                         "frames") as error:
        GenerateConfig(scenarios=("RoughTerrainObstacles",), jitter=(1.0,), episodes=1,
                       overrides={"frame": "none"})
    assert "\n" not in str(error.value)


def test_a_frameless_env_passes_sb3s_checker():
    # Not Gymnasium's check_env: its step-determinism check compares info with ==, and
    # the NaN ssim of every frameless step never equals itself.
    from stable_baselines3.common.env_checker import check_env

    env = make(frame="none", render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning fails the test
        check_env(env.unwrapped, warn=True)
    env.close()
