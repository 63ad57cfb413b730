"""LoomSteer (lgmd_sim.controllers.loom): its response to hand-made potentials of the two
eyes, its parameters' checks, and its eyes the same as a batch of cameras' sectors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from lgmd_sim.controllers import make
from lgmd_sim.controllers.loom import LoomSteer
from lgmd_sim.models.sectors import Sectors

THRESHOLD, REST = 0.9, 0.5
DT = 1 / 30
FRAME = {"frame": np.zeros((12, 16, 3), np.uint8)}


@dataclass
class _Out:
    potential: np.ndarray
    alarm: np.ndarray


class Eyes:
    """Stands in for the controller's two eyes: each step returns the next hand-made
    (left, right) potentials, alarming at or above THRESHOLD."""

    threshold = THRESHOLD

    def __init__(self, potentials):
        self.potentials = [np.asarray(p, float) for p in potentials]

    def reset(self):
        pass

    def rotation_from(self, info):
        return None

    def step(self, frame, rotation=None):
        p = self.potentials.pop(0)
        return _Out(p, p >= THRESHOLD)


def drive(potentials, goal_bearing=0.0, **params):
    """The actions of a LoomSteer fed `potentials`, one frame each, at 30 frames/s."""
    controller = LoomSteer(model="lgmd1", **params)
    controller.model = Eyes([(REST, REST), *potentials])
    actions, states = [], []
    for i in range(len(potentials) + 1):
        actions.append(controller.act(FRAME, {"time": i * DT, "goal_bearing": goal_bearing}))
        states.append(controller.manoeuvring)
    return np.array(actions[1:]), states[1:]


def test_it_turns_away_from_the_more_excited_eye():
    left, _ = drive([(0.8, 0.55)] * 10, smooth=0.0)
    right, _ = drive([(0.55, 0.8)] * 10, smooth=0.0)
    assert (left[:, 1] < 0).all() and (right[:, 1] > 0).all()  # < 0: turning right
    assert np.allclose(left[:, 1], -right[:, 1])
    assert (left[:, 0] < 0.6).all()  # slowed by the excitation
    quiet, _ = drive([(REST, REST)] * 10)
    assert np.allclose(quiet, [[0.6, 0.0]] * 10)


def test_it_keeps_turning_while_excited_and_heads_back_after():
    # an alarm on the left, the excitation staying high 1 s, then quiet
    potentials = [(0.95, 0.7)] * 3 + [(0.85, 0.6)] * 30 + [(REST, REST)] * 60
    actions, avoiding = drive(potentials, goal_bearing=0.5, smooth=0.0, hold=0.2,
                              release=0.5, memory=1.0)
    assert all(avoiding[:33]) and (actions[:33, 1] == -1.0).all()  # away: to the right
    assert not any(avoiding[40:])
    # the goal is to the left, where the obstacle was: not for `memory`, then towards it
    end = avoiding.index(False)
    assert (actions[end:end + 25, 1] == 0.0).all()
    assert (actions[end + 35:, 1] > 0.5).all()


def test_a_one_frame_surge_ends_its_avoidance_after_hold():
    _, avoiding = drive([(0.95, REST)] + [(REST, REST)] * 30, smooth=0.0, hold=0.3)
    assert avoiding[0] and 9 <= sum(avoiding) <= 10  # 0.3 s at 30 frames/s, and the alarm's
    short, _ = drive([(0.95, REST)] + [(REST, REST)] * 30, smooth=0.0, hold=0.0)
    assert sum(short[:, 0] < 0) == 1


def test_the_low_pass_damps_a_surge_that_does_not_alarm():
    sharp, _ = drive([(0.85, REST)] + [(REST, REST)] * 5, smooth=0.0)
    damped, _ = drive([(0.85, REST)] + [(REST, REST)] * 5, smooth=0.2)
    assert abs(damped[0, 1]) < abs(sharp[0, 1]) / 3


@pytest.mark.parametrize("bad, match", [
    ({"smooth": -1.0}, "smooth"), ({"release": 1.5}, "release"), ({"memory": float("nan")},
                                                                  "memory"),
    ({"slow": 2.0}, "slow"), ({"model": "nosuch"}, "nosuch"), ({"eye_overlap": 1.0}, "overlap"),
])
def test_bad_parameters_are_refused_in_one_line(bad, match):
    with pytest.raises(ValueError, match=match):
        make("loom-steer", **bad)


def test_its_eyes_are_one_camera_of_a_batch():
    """The controller's eyes, streaming, see what the same sectors batched over two
    cameras see for the first."""
    rng = np.random.default_rng(0)
    clips = rng.integers(0, 256, (2, 10, 36, 48, 3), dtype=np.uint8)
    controller = make("loom-steer", model="lgmd1", preset="robot-image")
    batch = Sectors("lgmd1", preset="robot-image", n_streams=2)
    for t in range(10):
        controller.act({"frame": clips[0, t]}, {"time": t * DT})
        together = batch.step(clips[:, t])
        assert controller.potential == together.potential[0].max()


def test_a_detector_drives_at_its_tuned_constants_under_the_callers(monkeypatch):
    from lgmd_sim.controllers import loom

    monkeypatch.setitem(loom.TUNED, "lgmd1/robot-image", {"steer_gain": 3.0, "memory": 2.0})
    tuned = make("loom-steer", model="lgmd1", preset="robot-image", memory=0.5)
    assert (tuned.params.steer_gain, tuned.params.memory) == (3.0, 0.5)
    other = make("loom-steer", model="lgmd1", preset="robot")
    assert other.params.steer_gain == loom.LoomParams().steer_gain
    # what a benchmark result records, resolved without building the controller
    assert loom.LoomSteer.resolve(model="lgmd1", preset="robot-image", memory=0.5) == tuned.params
