"""The privileged observation (the ground truth the Oracle reads) and `lgmd-sim train
--obs privileged`: the observation is the Oracle's inputs, clipped; a privileged policy
trains end to end and acts on a rendering environment."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import controllers
from lgmd_sim.controllers.avoid import OracleParams
from lgmd_sim.envs import JitterEnv
from lgmd_sim.envs.wrappers import PrivilegedObservation
from lgmd_sim.envs.wrappers.privileged import (
    SPEED_RANGE,
    THREAT_RANGE,
    TTC_RANGE,
    threat_features,
)
from lgmd_sim.envs.zone import in_trigger_zone


def _zone(threat: np.ndarray, params: OracleParams) -> bool:
    """`in_trigger_zone` from the observation alone."""
    distance, sin, cos, ttc, _ = (float(v) for v in threat)
    near = ttc < params.horizon or distance < params.clearance
    return near and abs(math.degrees(math.atan2(sin, cos))) <= params.ahead


def test_privileged_observation_matches_the_oracles_inputs():
    params = OracleParams()
    assert THREAT_RANGE > params.clearance and TTC_RANGE > params.horizon
    env = PrivilegedObservation(gym.make("lgmd_sim/RoughTerrainObstacles-v0",
                                         resolution="small"))
    zones = []
    # driving straight on: into the trigger zone, then into an obstacle
    for step in controllers.rollout(env, controllers.make("straight"), seed=0):
        obs, info = step.obs, step.info
        assert set(obs) == {"proprio", "goal", "threat"}
        assert obs["threat"].dtype == np.float32 and obs in env.observation_space
        bearing = info["threat_bearing"]
        np.testing.assert_array_equal(obs["threat"], np.array([
            np.clip(info["threat_distance"], -THREAT_RANGE, THREAT_RANGE), np.sin(bearing),
            np.cos(bearing), min(info["threat_ttc"], TTC_RANGE),
            np.clip(info["threat_closing_speed"], -SPEED_RANGE, SPEED_RANGE)], np.float32))
        np.testing.assert_allclose(obs["goal"], [
            info["goal_distance"], np.sin(info["goal_bearing"]), np.cos(info["goal_bearing"])],
            rtol=1e-6, atol=1e-6)
        zones.append(in_trigger_zone(info, params))
        assert _zone(obs["threat"], params) == zones[-1], step.index
    assert step.info["collision"] and 0 < sum(zones) < len(zones)  # both sides were seen
    env.close()


def test_no_threat_reads_as_far_and_never():
    features = threat_features({"threat_index": -1, "threat_distance": math.inf,
                                "threat_bearing": 0.0, "threat_closing_speed": 0.0,
                                "threat_ttc": math.inf})
    np.testing.assert_array_equal(features, [THREAT_RANGE, 0, 1, TTC_RANGE, 0])
    assert not _zone(features, OracleParams())


def test_privileged_spaces_pass_check_env():
    from gymnasium.utils.env_checker import check_env

    env = PrivilegedObservation(JitterEnv("PassBy", resolution="small"))
    assert "frame" not in env.observation_space.spaces
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any other checker warning fails the test
        warnings.filterwarnings("ignore", message=".*different from the unwrapped version")
        check_env(env, skip_render_check=True)
    env.close()
