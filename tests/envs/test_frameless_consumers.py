"""What reads the camera frames refuses a frameless environment (frame="none") before any
step, in one line, rather than a KeyError on obs["frame"] mid-episode."""

from __future__ import annotations

import gymnasium as gym
import pytest

import lgmd_sim  # noqa: F401 - registers the scenarios
from lgmd_sim import controllers
from lgmd_sim.apps.record import record

MESSAGE = r"has no 'frame' key \(frame='none'"


def test_reactive_avoid_refuses_a_frameless_env():
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", frame="none")
    with pytest.raises(ValueError, match=MESSAGE) as error:
        controllers.make("reactive").wrap_env(env)
    assert "\n" not in str(error.value)
    env.close()


def test_record_refuses_a_frameless_scenario_before_writing(tmp_path):
    path = tmp_path / "clip.mkv"
    with pytest.raises(ValueError, match=MESSAGE) as error:
        record("RoughTerrainObstacles", path, resolution="small", frame="none")
    assert "\n" not in str(error.value)
    assert not path.exists()
