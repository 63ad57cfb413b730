"""The benchmark's sanity baselines (lgmd_sim.benchmark.baselines): the simplest looming cue
and a random alarm, by their specs, keep the model contract and behave as their docs say."""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.benchmark.baselines import FrameDifference, RandomAlarm
from lgmd_sim.signals import stimuli

FD = "lgmd_sim.benchmark.baselines:FrameDifference"
RANDOM = "lgmd_sim.benchmark.baselines:RandomAlarm"


def potentials(model: models.LGMDModel, frames: np.ndarray) -> np.ndarray:
    """The model's potential at every frame (leading axis), one array per frame batched."""
    return np.array([model.step(f).potential for f in frames])


@pytest.fixture(scope="module")
def looming() -> stimuli.Stimulus:
    """An approach before a texture (48 x 64), three still frames first."""
    return stimuli.approaching((48, 64), start_distance=1.0, speed=2.0, still_frames=3,
                               look=stimuli.Look(background="texture"))


def noisy_still(n_frames: int, seed: int = 0) -> np.ndarray:
    """A still textured scene (48 x 64) under steady pixel noise."""
    scene = stimuli.static((48, 64), n_frames=n_frames).frames.astype(float)
    noise = np.random.default_rng(seed).normal(0.0, 3.0, scene.shape)
    return np.clip(scene + noise, 0, 255).astype(np.uint8)


def distinct_frames(streams: int, size: int = 8) -> np.ndarray:
    """One still frame per stream, each its own (the stream's index in its first pixels)."""
    frames = np.full((streams, size, size), 128, np.uint8)
    frames[:, 0, 0], frames[:, 0, 1] = np.arange(streams) % 256, np.arange(streams) // 256
    return frames


@pytest.mark.parametrize("spec, skipped", [(FD, set()), (RANDOM, {"front ends", "search space"})])
def test_baselines_keep_the_model_contract_by_their_specs(spec, skipped):
    done = dict(models.check_model(spec))
    assert {k for k, v in done.items() if v != "passed"} == skipped
    assert not {"frame_difference", "random_alarm"} & set(models.available())


def test_frame_difference_rests_at_half_on_a_still_scene_and_under_steady_noise():
    still = stimuli.static((48, 64), n_frames=40).frames
    assert (potentials(FrameDifference(), still) == 0.5).all()
    noisy = potentials(FrameDifference(), noisy_still(200))
    assert noisy.max() < 0.6  # the first change seeds the mean: no onset surge
    assert not any(FrameDifference().step(f).alarm for f in noisy_still(200))


def test_frame_difference_alarms_on_a_looming_clip_but_not_on_a_still_one(looming):
    model = models.make(FD)
    alarms = np.array([model.step(f).alarm for f in looming.frames])
    assert not alarms[:3].any() and alarms[3:looming.collision_frame + 1].any()
    model.reset()
    still = stimuli.static((48, 64), n_frames=len(looming)).frames
    assert not any(model.step(f).alarm for f in still)


def test_frame_difference_runs_with_a_front_end(looming):
    model = models.make(FD, preset="default+image")
    assert any(model.step(f).alarm for f in looming.frames)


@pytest.mark.parametrize("rate", [RandomAlarm.Params().rate_per_min, 60.0])
def test_random_alarm_rate_over_a_long_still_run_matches_rate_per_min(rate):
    streams, steps = 100, 300  # 30,000 frames: 100 streams of 10 s at 30 fps
    model = models.make(RANDOM, n_streams=streams, rate_per_min=rate)
    frames = distinct_frames(streams)
    alarms = sum(int(model.step(frames).alarm.sum()) for _ in range(steps))
    n, q = streams * steps, rate / 60.0 / 30.0
    assert abs(alarms - n * q) <= 4.0 * np.sqrt(n * q * (1.0 - q))  # binomial, 4 sd


def test_random_alarm_ignores_the_frames_after_the_first():
    first = distinct_frames(4)
    still = np.stack([first] * 60)
    noise = np.random.default_rng(0).random(still.shape[1:], np.float32)
    moving = [first] + [noise] * (len(still) - 1)  # float frames after the same first
    a = potentials(RandomAlarm(n_streams=4), still)
    b = potentials(RandomAlarm(n_streams=4), moving)
    assert np.array_equal(a, b)
    # the first frames differ per stream, and so do the draws: no lockstep across episodes
    assert len({tuple(column) for column in a.T}) == 4


def test_random_alarm_points_the_reactive_controller_to_either_half_at_random():
    model = RandomAlarm(n_streams=50)
    frames = distinct_frames(50, size=9)  # an odd width: the middle column is neither half
    sides = np.stack([model.step(frames, layers=True).layers["side"] for _ in range(20)])
    left, right = sides[..., :4].mean(axis=(2, 3)), sides[..., 5:].mean(axis=(2, 3))
    assert ((left == 1) ^ (right == 1)).all() and not sides[..., 4].any()
    assert 0.4 < (left == 1).mean() < 0.6  # 1000 draws: 0.5 +/- 0.016


def test_random_alarm_is_reproducible_and_its_seed_changes_the_draws():
    frames = np.stack([distinct_frames(3)] * 50)
    a = potentials(RandomAlarm(n_streams=3), frames)
    assert np.array_equal(a, potentials(RandomAlarm(n_streams=3), frames))
    other = potentials(RandomAlarm(RandomAlarm.Params(seed=1), n_streams=3), frames)
    assert not np.array_equal(a, other)


def test_random_alarm_refuses_a_rate_above_one_alarm_a_frame_naming_it():
    with pytest.raises(ValueError, match=r"^RandomAlarmParams: parameter rate_per_min=2000\.0 "
                                         r"exceeds one alarm a frame at fps=30\.0"):
        RandomAlarm.Params(rate_per_min=2000.0)
