"""The Gymnasium environments: registration, checkers, API contract, seeding, resources."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401 - registers the scenarios
from lgmd_sim.cli import envs as cli_envs
from lgmd_sim.envs import catalogue

SCENARIOS = ["StationaryApproach", "HandheldApproach", "MutualApproach",
             "RoughTerrainObstacles", "PassBy", "ArenaRoam"]


def make(name: str = "RoughTerrainObstacles", **overrides) -> gym.Env:
    overrides.setdefault("resolution", "small")
    return gym.make(f"lgmd_sim/{name}-v0", **overrides)


def test_catalogue_registers_every_scenario_without_importing_mujoco():
    assert set(SCENARIOS) <= set(catalogue.scenarios())
    for name in catalogue.scenarios():
        assert f"lgmd_sim/{name}-v0" in gym.registry
    code = ("import sys, lgmd_sim, gymnasium; "
            "assert 'lgmd_sim/PassBy-v0' in gymnasium.registry; "
            "assert 'mujoco' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_envs_command_lists_scenarios_with_parameters(capsys):
    assert cli_envs.run(argparse.Namespace(name=None)) == 0
    out = capsys.readouterr().out
    for name in SCENARIOS:
        assert f"lgmd_sim/{name}-v0" in out
    assert cli_envs.run(argparse.Namespace(name="PassBy")) == 0
    out = capsys.readouterr().out
    assert "miss_distance = 1.0" in out and "jitter" in out and "time_limit" in out
    with pytest.raises(ValueError, match="unknown scenario"):
        cli_envs.run(argparse.Namespace(name="Nope"))


@pytest.mark.parametrize("name", SCENARIOS)
def test_gymnasium_and_sb3_checkers_pass(name):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make(name, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning fails the test
        check_env(env.unwrapped)
        sb3_check_env(env.unwrapped, warn=True)
    env.close()


def test_observation_action_and_metadata():
    env = make(frame="grey", render_mode="rgb_array")
    assert env.metadata["render_modes"] == ["rgb_array"] and env.metadata["render_fps"] == 30
    obs, info = env.reset(seed=0)
    assert obs["frame"].shape == (64, 64, 1) and obs["frame"].dtype == np.uint8
    assert obs["proprio"].shape == (11,) and obs["proprio"].dtype == np.float32
    assert obs["goal"].shape == (3,) and obs["goal"][0] == pytest.approx(
        info["goal_distance"], rel=1e-5)
    assert env.observation_space.contains(obs)
    obs, *_ = env.step(np.array([1.0, 0.0], np.float32))
    assert obs["proprio"][:2].min() > 1.0  # the wheels turn forward
    assert obs["proprio"][7] == pytest.approx(9.81, abs=3.0)  # the IMU feels gravity
    assert env.render().shape == (64, 64, 3)
    env.close()
    assert make(name="PassBy").observation_space["frame"].shape == (64, 64, 3)
    assert "goal" not in make(name="PassBy").observation_space.spaces


def test_actions_are_checked_and_clipped():
    a, b = make(), make()
    a.reset(seed=1)
    b.reset(seed=1)
    for bad in ([np.nan, 0.0], [0.0, np.inf], [1.0, 2.0, 3.0]):
        with pytest.raises(ValueError, match="action"):
            a.step(np.array(bad))
    for _ in range(3):
        oa, ra, *_ = a.step(np.array([7.0, -3.0]))
        ob, rb, *_ = b.step(np.array([1.0, -1.0]))
        assert np.array_equal(oa["frame"], ob["frame"]) and ra == rb
    a.close()
    b.close()


@pytest.mark.parametrize("overrides, error", [
    (dict(roughness=-1.0), "roughness"),
    (dict(resolution=[0, 64]), "resolution"),
    (dict(resolution=[64, 100000]), "resolution"),
    (dict(warp_drive=True), "unknown parameter"),
])
def test_invalid_parameters_raise_value_errors(overrides, error):
    overrides.setdefault("resolution", "small")
    with pytest.raises(ValueError, match=error):
        gym.make("lgmd_sim/PassBy-v0", **overrides)


@pytest.mark.parametrize("spelling", ["270x480", "270X480"])
def test_a_resolution_spelt_as_on_the_command_line_makes_the_same_frames(spelling):
    # the API refused the CLI's spelling
    env, reference = (make(name="PassBy", resolution=r, jitter=0.0) for r in (spelling,
                                                                               [270, 480]))
    assert env.unwrapped.params.resolution == reference.unwrapped.params.resolution
    assert env.observation_space == reference.observation_space
    (frame, _), (expected, _) = env.reset(seed=3), reference.reset(seed=3)
    assert frame["frame"].shape == (270, 480, 3)
    assert np.array_equal(frame["frame"], expected["frame"])
    env.close()
    reference.close()


@pytest.mark.parametrize("spelling", ["270by480", "270x", "8x8", "270x480x3"])
def test_a_resolution_that_is_no_frame_size_is_one_line_naming_it(spelling):
    with pytest.raises(ValueError) as exc:
        make(resolution=spelling)
    message = str(exc.value)
    assert repr(spelling) in message and "HEIGHTxWIDTH" in message and "\n" not in message


def test_unsupported_render_mode_is_refused():
    from lgmd_sim.envs import JitterEnv

    with pytest.raises(ValueError, match="render_mode"):
        JitterEnv("PassBy", render_mode="depth_array", resolution="small")


def test_unknown_id_is_a_clear_gymnasium_error():
    with pytest.raises(gym.error.Error, match="NoSuchScenario"):
        gym.make("lgmd_sim/NoSuchScenario-v0")


def test_overrides_reach_the_world():
    env = make(name="PassBy", jitter=1.5, fps=15.0, time_limit=2.0)
    params = env.unwrapped.params
    assert params.jitter == 1.5 and params.max_steps == 30
    assert env.metadata["render_fps"] == 15.0
    env.close()


def test_collision_terminates_with_penalty_and_goal_rewards_progress():
    env = make(n_obstacles=1, obstacle_kinds=["box"], obstacle_ahead=1.0, jitter=0.0,
               goal_distance=6.0)
    env.reset(seed=0)
    rewards = []
    for _ in range(60):
        _obs, reward, terminated, truncated, info = env.step([1.0, 0.0])
        rewards.append(reward)
        if terminated:
            break
    assert terminated and not truncated and info["collision"]
    assert info["first_collision_frame"] == info["frame_index"] and not info["goal_reached"]
    assert rewards[-1] < -9.0 and all(0 < r < 0.1 for r in rewards[5:-2])
    env.close()

    env = make(n_obstacles=0, obstacle_ahead=0.0, jitter=0.0, goal_distance=1.0,
               goal_radius=0.4)
    _obs, info = env.reset(seed=0)
    start, total, steps = info["goal_distance"], 0.0, 0
    terminated = False
    while not terminated and steps < 60:
        _obs, reward, terminated, truncated, info = env.step([1.0, 0.0])
        total += reward
        steps += 1
    assert terminated and info["goal_reached"] and not info["collision"]
    assert info["goal_distance"] < 0.4
    # progress (1 per metre) minus the effort penalty (0.01 per step at full action)
    assert total == pytest.approx(start - info["goal_distance"] - 0.01 * steps, abs=1e-6)
    env.close()


def test_time_limit_truncates():
    env = make(name="PassBy", time_limit=0.2)
    env.reset(seed=0)
    flags = [env.step([0.0, 0.0])[2:4] for _ in range(6)]
    assert flags[-1] == (False, True) and not any(any(f) for f in flags[:-1])
    env.close()


def test_render_camera_and_chase_view():
    env = make(name="HandheldApproach", render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    assert np.array_equal(env.render(), obs["frame"])
    chase = make(name="HandheldApproach", render_mode="rgb_array", render_camera="chase")
    chase.reset(seed=0)
    view = chase.render()
    assert view.shape == obs["frame"].shape and not np.array_equal(view, obs["frame"])
    quiet = make(name="PassBy")
    quiet.reset(seed=0)
    assert quiet.render() is None
    quiet.close()
    env.close()
    chase.close()


def test_seeding_is_bit_identical():
    def run(seed):
        env = make(n_obstacles=4, mover="ball", render_mode=None)
        out = [env.reset(seed=seed)]
        out += [env.step([0.8, 0.4])[::4] for _ in range(6)]  # (obs, info)
        out.append(env.reset())  # the next episode follows from the seed too
        env.close()
        return out

    a, b, c = run(5), run(5), run(6)
    for (oa, ia), (ob, ib) in zip(a, b, strict=True):
        assert np.array_equal(oa["frame"], ob["frame"])
        assert np.array_equal(oa["proprio"], ob["proprio"])
        for key in ia:
            assert np.array_equal(ia[key], ib[key], equal_nan=True), key
    assert not np.array_equal(a[0][0]["frame"], c[0][0]["frame"])


def test_close_is_idempotent():
    env = make()
    env.reset(seed=0)
    env.close()
    env.close()
    with pytest.raises(RuntimeError):
        env.unwrapped.world.render_camera()


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def _threads() -> int:
    return len(os.listdir("/proc/self/task"))


@pytest.mark.slow
def test_making_and_closing_200_envs_leaks_nothing():
    def cycle():
        env = make(name="PassBy", scenery=2)
        env.reset(seed=0)
        env.step([0.0, 0.0])
        env.close()

    for _ in range(20):  # warm up: allocator pools, GL context of this thread
        cycle()
    rss, fds, threads = _rss_mb(), _open_fds(), _threads()
    for _ in range(200):
        cycle()
    assert _open_fds() <= fds + 2  # GL contexts hold file descriptors and threads
    assert _threads() <= threads + 2
    assert _rss_mb() - rss < 40, f"RSS grew {(_rss_mb() - rss):.1f} MB over 200 envs"


def test_async_vector_env_each_worker_with_its_own_context():
    # This process has rendered already (earlier tests): forking workers must still work.
    first = make(name="PassBy")
    first.reset(seed=0)
    envs = gym.make_vec("lgmd_sim/PassBy-v0", 2, vectorization_mode="async",
                        resolution="small")
    obs, info = envs.reset(seed=0)
    for _ in range(3):
        obs, _reward, _term, _trunc, info = envs.step(np.zeros((2, 2), np.float32))
    assert obs["frame"].shape == (2, 64, 64, 3)
    assert not np.array_equal(obs["frame"][0], obs["frame"][1])  # seeds 0 and 1
    assert info["frame_index"].tolist() == [3, 3]
    envs.close()
    first.step([0.0, 0.0])  # the parent renders on after the fork
    first.close()


@pytest.mark.slow
def test_sb3_subproc_vec_env():
    from stable_baselines3.common.vec_env import SubprocVecEnv

    def factory():  # runs in a fresh worker: "lgmd_sim:" imports lgmd_sim there first
        return gym.make("lgmd_sim:lgmd_sim/StationaryApproach-v0", resolution="small")

    venv = SubprocVecEnv([factory, factory])
    venv.seed(3)
    obs = venv.reset()
    obs, _rewards, _dones, infos = venv.step(np.zeros((2, 2), np.float32))
    assert obs["frame"].shape == (2, 64, 64, 3) and len(infos) == 2
    assert obs["frame"].max() > 0
    venv.close()
