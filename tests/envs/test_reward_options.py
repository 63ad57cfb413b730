"""Reward shaping options of the environment: off by default, each its stated amount."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401 - registers the scenarios
from lgmd_sim.envs.zone import TriggerZone, in_trigger_zone

OPTIONS = ("goal_bonus", "time_penalty", "proximity_penalty")
OBSTACLE_AHEAD = dict(n_obstacles=1, obstacle_kinds=["box"], obstacle_ahead=1.5, jitter=0.0,
                      goal_distance=6.0, terminate_on_collision=False)
GOAL_NEAR = dict(n_obstacles=0, obstacle_ahead=0.0, jitter=0.0, goal_distance=1.0,
                 goal_radius=0.4)


def episode(steps: int = 45, action=(1.0, 0.0), **overrides) -> list[tuple[float, dict]]:
    """(reward, info) of each step of one seeded episode, driving with `action`; frameless,
    as rewards do not depend on the frames (tests/envs/test_frameless.py)."""
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", frame="none",
                   **overrides)
    _obs, info = env.reset(seed=0)
    out = []
    for _ in range(steps):
        _obs, reward, terminated, truncated, info = env.step(action)
        out.append((reward, info))
        if terminated or truncated:
            break
    env.close()
    return out


def test_defaults_give_exactly_the_task_reward():
    actions = np.random.default_rng(1).uniform(-1, 1, (40, 2))
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", frame="none")
    _obs, info = env.reset(seed=2)
    before = info["goal_distance"]
    for a in actions:
        _obs, reward, terminated, truncated, info = env.step(a)
        # the reward before the options, term by term in the same order
        task = -0.01 * float(a @ a)
        if info["collision"]:
            task -= 10.0
        task += 1.0 * (before - info["goal_distance"])
        before = info["goal_distance"]
        assert reward == task == info["task_reward"]
        if terminated or truncated:
            break
    env.close()
    unset = episode(**OBSTACLE_AHEAD)
    zeros = episode(**OBSTACLE_AHEAD, **dict.fromkeys(OPTIONS, 0.0))
    assert [r for r, _ in unset] == [r for r, _ in zeros]


def test_goal_bonus_is_added_once_on_reaching_the_goal():
    plain, shaped = episode(**GOAL_NEAR), episode(**GOAL_NEAR, goal_bonus=5.0)
    assert shaped[-1][1]["is_success"] and len(shaped) == len(plain)
    for (r0, _), (r, i) in zip(plain, shaped, strict=True):
        assert i["task_reward"] == r0
        assert r - r0 == pytest.approx(5.0 if i["is_success"] else 0.0, abs=1e-12)


def test_time_penalty_is_per_second():
    fps = 15.0
    plain, shaped = episode(**GOAL_NEAR, fps=fps), episode(**GOAL_NEAR, fps=fps,
                                                           time_penalty=0.3)
    for (r0, _), (r, i) in zip(plain, shaped, strict=True):
        assert i["task_reward"] == r0
        assert r - r0 == pytest.approx(-0.3 / fps, abs=1e-12)


def test_proximity_penalty_is_per_second_in_the_oracles_trigger_zone():
    plain, shaped = episode(**OBSTACLE_AHEAD), episode(**OBSTACLE_AHEAD, proximity_penalty=2.0)
    zone = [in_trigger_zone(i, TriggerZone()) for _, i in shaped]
    assert any(zone) and not all(zone)  # it drives into the zone, from outside it
    for (r0, _), (r, i), inside in zip(plain, shaped, zone, strict=True):
        assert i["task_reward"] == r0
        assert r - r0 == pytest.approx(-2.0 / 30.0 if inside else 0.0, abs=1e-12)


@pytest.mark.parametrize("key", OPTIONS)
@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf"), True, "5"])
def test_bad_option_values_are_refused_in_one_line(key, value):
    with pytest.raises(ValueError, match=f"parameter {key}=.* must be a finite number >= 0"
                       ) as error:
        gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", frame="none",
                 **{key: value})
    assert "\n" not in str(error.value)


def test_validation_scores_the_task_reward_not_the_shaped_one():
    pytest.importorskip("stable_baselines3")
    from lgmd_sim.training.callbacks import _task_rewards

    [(shaped, info)] = episode(1, time_penalty=1.0)
    assert shaped != info["task_reward"]
    # the second environment's info has no task reward: its reward counts as it is
    summed = _task_rewards(np.array([shaped, 0.25]), [info, {}])
    np.testing.assert_array_equal(summed, [info["task_reward"], 0.25])
