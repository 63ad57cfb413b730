"""Sectors ("two eyes"): one LGMD per overlapping part of the view, and the reactive
controller that turns away from the more excited eye."""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.controllers import make as make_controller
from lgmd_sim.models.sectors import Sectors, sector_boxes
from lgmd_sim.models.stabilize import intrinsics, rotation_homography
from lgmd_sim.models.warp import Motion

SHAPE = (36, 48)
FRAMES = 8
FRONT_ENDS = ("", "+image", "+imu", "+imu+gain")


def _looming(centre: float, shape: tuple[int, int] = SHAPE, frames: int = FRAMES,
             seed: int = 0, drift: int = 1) -> np.ndarray:
    """A dark square growing at `centre` (a fraction of the width) over a light textured
    background that drifts `drift` pixels a frame: uint8 frames (T, H, W)."""
    h, w = shape
    rng = np.random.default_rng(seed)
    texture = rng.integers(150, 256, (h, w + drift * frames), dtype=np.uint8)
    out = np.empty((frames, h, w), np.uint8)
    for t in range(frames):
        out[t] = texture[:, drift * t:drift * t + w]
        half = 1 + t * min(h, w) // (6 * frames)
        cx, cy = int(centre * w), h // 2
        out[t, cy - half:cy + half, max(cx - half, 0):cx + half] = 20
    return out


def _turns(frames: int, seed: int) -> np.ndarray:
    return np.radians(0.5) * np.random.default_rng(seed).normal(size=(frames, 3))


def _spec(name: str, front: str) -> str:
    return next(iter(models.presets_of(name))) + front


def _same(a, b) -> None:
    assert np.array_equal(a.potential, b.potential) and np.array_equal(a.alarm, b.alarm)
    assert (a.layers is None) == (b.layers is None)
    for k in a.layers or {}:
        assert np.array_equal(a.layers[k], b.layers[k]), k


@pytest.mark.parametrize("front", FRONT_ENDS)
@pytest.mark.parametrize("name", models.available())
def test_a_batch_of_cameras_is_exactly_as_many_single_cameras(name, front):
    clips = [_looming(0.3, seed=1), _looming(0.7, seed=2)]
    turns = [_turns(FRAMES, 1), _turns(FRAMES, 2)]
    imu = "+imu" in front
    batch = Sectors(name, preset=_spec(name, front), columns=2, rows=2, n_streams=2)
    singles = [Sectors(name, preset=_spec(name, front), columns=2, rows=2) for _ in clips]
    for t in range(FRAMES):
        if t == 5:  # the second camera starts anew mid-way
            batch.reset([1])
            singles[1].reset()
        out = batch.step(np.stack([c[t] for c in clips]), layers=True,
                         rotation=np.stack([r[t] for r in turns]) if imu else None)
        assert out.potential.shape == (2, 4) and out.layers["S"].shape[:2] == (2, 4)
        for i, single in enumerate(singles):
            one = single.step(clips[i][t], layers=True, rotation=turns[i][t] if imu else None)
            assert one.potential.shape == (4,)
            _same(one, type(one)(out.potential[i], out.alarm[i],
                                 {k: v[i] for k, v in out.layers.items()}))


@pytest.mark.parametrize("front", FRONT_ENDS)
@pytest.mark.parametrize("name", models.available())
def test_one_sector_over_the_whole_frame_is_the_model(name, front):
    clip, turns = _looming(0.4), _turns(FRAMES, 3)
    imu = "+imu" in front
    plain = models.make(name, preset=_spec(name, front))
    one = Sectors(name, preset=_spec(name, front), columns=1, rows=1, overlap=0.0)
    assert one.boxes is None
    for t in range(FRAMES):
        rotation = turns[t] if imu else None
        a = plain.step(clip[t], layers=True, rotation=rotation)
        b = one.step(clip[t], layers=True, rotation=rotation)
        _same(type(a)(np.array([a.potential]), np.array([a.alarm]),
                      {k: v[None] for k, v in a.layers.items()}), b)
    assert one.boxes == [(0, SHAPE[0], 0, SHAPE[1])]
    assert one.threshold == plain.params.threshold
    assert one.rotation_key == plain.rotation_key


@pytest.mark.parametrize("name", models.available())
def test_each_eye_is_the_model_given_its_part_of_the_frame(name):
    grey = _looming(0.3)
    colour = np.stack([grey, grey // 2, 255 - grey], axis=-1).astype(np.float64) / 255
    eyes = Sectors(name)
    alone = [models.make(name) for _ in range(2)]
    for f in colour:
        out = eyes.step(f, layers=True)
        for i, (top, bottom, left, right) in enumerate(eyes.boxes):
            a = alone[i].step(f[top:bottom, left:right], layers=True)
            assert out.potential[i] == a.potential and out.alarm[i] == a.alarm
            assert np.array_equal(out.layers["S"][i], a.layers["S"])


def test_a_given_motion_reaches_each_sector_as_its_crop_sees_it():
    clip, k = _looming(0.5), intrinsics(55.0, *SHAPE)
    pan = rotation_homography(np.radians([0.5, 1.5, 2.0]), k)  # a roll: not a shift
    ground = rotation_homography(np.radians([-1.0, 0.5, -1.0]), k)
    horizon = np.array([0.3, 1.0, -25.0])  # tilted: a crop's offset moves it
    gain = np.broadcast_to(np.linspace(0.8, 1.2, SHAPE[1], dtype=np.float32), SHAPE)
    whole, eyes = models.make("lgmd1"), Sectors("lgmd1", overlap=0.2)
    for t in range(3):
        motion = Motion(pan, gain, horizon, ground) if t else None
        a = whole.step(clip[t], layers=True, motion=motion)
        b = eyes.step(clip[t], layers=True, motion=motion)
    # away from a crop's sides (what the warp uncovers there, and the kernels' border),
    # each eye's maps are the whole frame's
    for (top, bottom, left, right), s in zip(eyes.boxes, b.layers["S"], strict=True):
        assert np.allclose(s[:, 6:-6], a.layers["S"][top:bottom, left + 6:right - 6],
                           atol=1e-4)


def test_the_boxes_of_two_eyes_and_of_quadrants():
    assert sector_boxes(120, 160) == [(0, 120, 0, 96), (0, 120, 64, 160)]  # 0-60%, 40-100%
    quads = sector_boxes(120, 160, columns=2, rows=2, overlap=0.0)
    assert quads == [(0, 60, 0, 80), (0, 60, 80, 160), (60, 120, 0, 80), (60, 120, 80, 160)]
    for h, w, c, r, o in [(36, 48, 3, 2, 0.0), (37, 101, 4, 3, 0.1), (10, 10, 3, 1, 0.0)]:
        boxes = sector_boxes(h, w, c, r, o)
        assert len(boxes) == c * r and len({(b - t, rt - le) for t, b, le, rt in boxes}) == 1
        covered = np.zeros((h, w), bool)
        for t, b, le, rt in boxes:
            assert 0 <= t < b <= h and 0 <= le < rt <= w
            covered[t:b, le:rt] = True
        assert covered.all(), (h, w, c, r, o)


@pytest.mark.parametrize("name", models.available())
def test_the_eye_on_the_looming_side_is_the_more_excited(name):
    for centre, excited in ((0.2, 0), (0.8, 1)):
        eyes = Sectors(name)
        clip = _looming(centre, frames=10, drift=0)
        potentials = np.array([eyes.step(f).potential for f in clip])
        assert potentials.shape == (10, 2)
        near, far = potentials[:, excited], potentials[:, 1 - excited]
        assert (near >= far).all() and near.max() > far.max() + 0.1, (centre, name)


def _actions(controller, clip: np.ndarray) -> list[np.ndarray]:
    controller.reset()
    return [controller.act({"frame": f}, {"time": t / 30}) for t, f in enumerate(clip)]


# "halves" with lgmd1 turned towards the threat while it compared the halves' mean S: its S
# layer is signed, and a dark square makes the mean S of its half negative
@pytest.mark.parametrize(("side", "model"), [("eyes", "lgmd1"), ("eyes", "lgmd2"),
                                             ("eyes", "f_off"), ("halves", "lgmd1"),
                                             ("halves", "lgmd2")])
def test_reactive_avoid_turns_away_from_the_looming_side(side, model):
    for centre, turn in ((0.2, -1.0), (0.8, 1.0)):  # on the left: turn right (negative)
        controller = make_controller("reactive", model=model, side=side)
        actions = _actions(controller, _looming(centre, frames=10, drift=0))
        turning = [a for a in actions if a[1] != 0.0]
        assert turning and all(a[1] == turn for a in turning), (side, centre, actions)
        assert controller.manoeuvring
        assert controller.potential > controller.model.params.threshold


def test_eyes_alarm_on_either_eye_and_report_the_larger_potential():
    controller = make_controller("reactive", model="lgmd1", side="eyes", eye_overlap=0.3,
                                 model_params={"threshold": 0.7})
    eyes = Sectors("lgmd1", overlap=0.3, threshold=0.7)
    controller.reset()
    alarms = []
    for t, f in enumerate(_looming(0.2, frames=10, drift=0)):
        controller.act({"frame": f}, {"time": t / 30})
        out = eyes.step(f)
        assert controller.potential == out.potential.max()
        assert controller.alarm == out.alarm.any()
        alarms.append(out.alarm)
    assert np.array(alarms)[:, 0].any() and not np.array(alarms)[:, 1].any()  # left only


def test_bad_arguments_are_refused_by_name():
    for bad, match in [({"columns": 0}, "columns"), ({"rows": 1.5}, "rows"),
                       ({"columns": True}, "columns"), ({"overlap": 1.0}, "overlap"),
                       ({"overlap": -0.1}, "overlap"), ({"overlap": "0.2"}, "overlap"),
                       ({"gamma": 1.0}, "gamma"), ({"preset": "nope"}, "nope")]:
        with pytest.raises(ValueError, match=match):
            Sectors("lgmd1", **bad)
    with pytest.raises(ValueError, match="lgmd9"):
        Sectors("lgmd9")
    with pytest.raises(ValueError, match=r"sectors: 30 x 1 sectors of a 36x48 frame are 36x2"):
        Sectors("lgmd1", columns=30, overlap=0.0).step(_looming(0.5)[0])
    eyes = Sectors("lgmd1")
    eyes.step(_looming(0.5)[0])
    with pytest.raises(ValueError, match="frame size 20x48 differs"):
        eyes.step(np.zeros((20, 48), np.uint8))
    with pytest.raises(ValueError, match="rotation= needs"):
        eyes.step(_looming(0.5)[0], rotation=np.zeros(3))
    with pytest.raises(ValueError, match="reset"):
        eyes.reset([0])  # one camera: no stream indices
    with pytest.raises(ValueError, match="out of range"):
        Sectors("lgmd1", n_streams=2).reset([2])
    with pytest.raises(ValueError, match="motion="):
        Sectors("lgmd1", preset="published+image").step(_looming(0.5)[0],
                                                        motion=Motion(np.eye(3)))
    for bad, match in [({"side": "both"}, "side"), ({"eye_overlap": 1.0}, "eye_overlap")]:
        with pytest.raises(ValueError, match=match):
            make_controller("reactive", **bad)
