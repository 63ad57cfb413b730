"""Controllers and `rollout`, the episode loop the tools share."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim.controllers import Straight, rollout


def test_straight_turns_towards_the_goal_and_clips():
    c = Straight(cruise=0.6, heading_gain=1.5)
    assert c.act({}, {"goal_bearing": 0.2}).tolist() == pytest.approx([0.6, 0.3])
    assert c.act({}, {"goal_bearing": -3.0}).tolist() == pytest.approx([0.6, -1.0])
    assert c.act({}, {}).tolist() == pytest.approx([0.6, 0.0])  # no goal: straight on
    with pytest.raises(ValueError, match="cruise"):
        Straight(cruise=2.0)


def test_rollout_yields_every_frame_with_the_action_taken_on_it():
    env = gym.make("lgmd_sim/StationaryApproach-v0", resolution="small", time_limit=1.0)
    steps = list(rollout(env, Straight(), seed=4))
    assert [s.index for s in steps] == list(range(len(steps)))
    assert [s.info["frame_index"] for s in steps] == [s.index for s in steps]
    assert all(s.action is not None for s in steps[:-1]) and steps[-1].action is None
    last = steps[-1]
    assert (last.terminated or last.truncated) and not any(
        s.terminated or s.truncated for s in steps[:-1])
    # the same episode stepped by hand gives the same frames
    obs, _ = env.reset(seed=4)
    assert np.array_equal(obs["frame"], steps[0].obs["frame"])
    for s in steps[1:]:
        obs, reward, *_ = env.step(steps[s.index - 1].action)
        assert np.array_equal(obs["frame"], s.obs["frame"]) and reward == s.reward
    env.close()


def test_reactive_avoid_feeds_a_stabilized_model_its_rotation():
    from lgmd_sim.controllers import make

    env = gym.make("lgmd_sim/HandheldApproach-v0", resolution="small", time_limit=1.0)
    traces = {}
    for preset in ("published", "published+imu", "published+pose", "published+image"):
        controller = make("reactive", model="lgmd1", preset=preset)
        # a pose- or IMU-stabilized model fails without its rotation: these run through
        traces[preset] = [controller.potential for _ in rollout(env, controller, seed=2)]
    assert len(traces["published"]) > 10
    for preset in ("published+imu", "published+pose", "published+image"):
        assert traces[preset] != traces["published"], preset  # the shake is taken out
    with pytest.raises(ValueError, match="front end"):
        make("reactive", model="lgmd1", preset="published+wobble")
    env.close()


def test_only_controllers_that_can_tell_report_manoeuvring():
    """None: cannot tell (a trained policy turns away without saying so); Straight never
    manoeuvres; the avoiders say when they do."""
    from lgmd_sim.controllers import Controller, make
    from lgmd_sim.controllers.policy import Policy

    assert Controller.manoeuvring is None and Policy.manoeuvring is None
    assert Straight().manoeuvring is False
    assert make("oracle").manoeuvring is False  # not yet: nothing triggered it


def test_steer_acts_on_the_frame_alone_and_reaches_the_goal():
    """`Steer`: the Oracle's inputs without its memory. The same frame gives the same action
    whatever came before (the Oracle, mid-manoeuvre, does not), and on a search seed of
    its constants it drives to the goal without touching anything."""
    from lgmd_sim.controllers import make

    frames = [{"time": 0.1 * t, "threat_bearing": 0.3, "threat_distance": 0.2,
               "threat_ttc": 0.5, "goal_bearing": 0.0} for t in range(3)]
    calm = {"time": 0.3, "threat_bearing": 0.3, "threat_distance": 5.0,
            "threat_ttc": float("inf"), "goal_bearing": 0.2}
    for name, memoryless in (("steer", True), ("oracle", False)):
        after_threats, fresh = make(name), make(name)
        for info in frames:
            after_threats.act({}, info)
        same = np.array_equal(after_threats.act({}, calm), fresh.act({}, calm))
        assert same is memoryless, name
    steer = make("steer")
    assert steer.act({}, frames[0])[1] < 0 and steer.manoeuvring  # threat left: turn right
    assert not (steer.act({}, calm), steer.manoeuvring)[1]

    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", frame="none")
    try:
        last = list(rollout(env, make("steer"), seed=2000))[-1]
    finally:
        env.close()
    assert last.info["goal_reached"] and last.info["first_collision_frame"] < 0
