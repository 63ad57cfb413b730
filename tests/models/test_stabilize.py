"""Ego-motion compensation: warping a model's state, the front ends, the world's IMU."""

import itertools

import cv2
import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.models.stabilize import (
    ImageRotation,
    brightness_gain,
    intrinsics,
    rotation_homography,
    rotation_matrix,
    rotation_vector,
)
from lgmd_sim.models.warp import Motion
from lgmd_sim.signals import stimuli
from scripts.speed.stabilize import rotating_scene

from footage import camera_turns, turning_scene

MODELS = models.available()
SHAPE = (48, 64)
#: Model variants whose stored maps differ: persistence, low-pass inhibition, borders.
VARIANTS = [(n, None) for n in MODELS] + [("lgmd1", "plgmd"), ("lgmd2", "v0.1"),
                                          ("f_on", "v0.1")]


@pytest.fixture(scope="module")
def clip() -> np.ndarray:
    return stimuli.approaching(SHAPE, still_frames=2,
                               look=stimuli.Look(background="texture", seed=1)).frames[-8:]


@pytest.mark.parametrize(("name", "preset"), VARIANTS)
def test_an_identity_motion_changes_nothing(name, preset, clip):
    plain, moved = models.make(name, preset=preset), models.make(name, preset=preset)
    for frame in clip:
        a = plain.step(frame, layers=True)
        b = moved.step(frame, layers=True, motion=Motion(np.eye(3), 1.0))
        assert a.potential == b.potential
        for key in a.layers:
            assert np.array_equal(a.layers[key], b.layers[key])


@pytest.mark.parametrize(("name", "preset"), VARIANTS)
def test_a_batch_is_warped_exactly_as_separate_streams(name, preset, clip):
    n = 3
    k = intrinsics(55.0, *SHAPE)
    turns = camera_turns(len(clip) * n, seed=2, degrees=2.0).reshape(len(clip), n, 3)
    gains = (1.0 + 0.05 * np.random.default_rng(3).normal(size=(len(clip), n, *SHAPE))
             ).astype(np.float32)  # gain fields
    frames = np.stack([np.roll(clip, 3 * i, axis=2) for i in range(n)], axis=1)
    batch = models.make(name, preset=preset, n_streams=n)
    alone = [models.make(name, preset=preset) for _ in range(n)]
    for t in range(len(clip)):
        hs = rotation_homography(turns[t], k)
        out = batch.step(frames[t], layers=True, motion=Motion(hs, gains[t]))
        for i, m in enumerate(alone):
            one = m.step(frames[t, i], layers=True, motion=Motion(hs[i], gains[t, i]))
            assert one.potential == out.potential[i]
            for key in one.layers:
                assert np.array_equal(one.layers[key], out.layers[key][i]), (t, i, key)


def test_uncovered_pixels_see_no_change(clip):
    """A camera turned by 4 pixels: the strip it uncovers has P = 0 (its previous frame is
    the current one), the rest is the previous frame moved."""
    m = models.make("lgmd1")
    m.step(clip[0])
    shift = np.array([[1.0, 0, 4], [0, 1, 0], [0, 0, 1]])  # content moves 4 px right
    out = m.step(clip[1], layers=True, motion=Motion(shift))
    p = out.layers["P"]
    assert np.all(p[:, :4] == 0)
    expect = clip[1][:, 4:].astype(np.float32) - clip[0][:, :-4]
    assert np.allclose(p[:, 4:], expect, atol=1e-3)


@pytest.mark.parametrize("name", MODELS)
def test_the_camera_rotation_removed_leaves_a_still_scene_nearly_still(name):
    frames, turns = turning_scene(6, (72, 96))
    plain = models.make(name)
    pose = models.make(name, stabilize="pose")
    for f, r in zip(frames, turns, strict=True):
        a, b = plain.step(f, layers=True), pose.step(f, layers=True, rotation=r)
    assert np.abs(b.layers["P"]).mean() < 0.2 * np.abs(a.layers["P"]).mean()


def test_image_fit_finds_the_rotation():
    frames, turns = turning_scene(8, (135, 240), seed=4)
    fit = ImageRotation(55.0)
    flip = np.diag([1.0, -1.0, -1.0])
    for f, r in zip(frames, turns, strict=True):
        rot, inliers = fit.update(f)
        found = rotation_vector((flip @ rot @ flip).T)  # back to MuJoCo's camera frame
        assert np.degrees(np.linalg.norm(found - r)) < 0.05
    assert inliers >= 20


def test_image_front_end_matches_the_given_rotation():
    frames, turns = turning_scene(6, (135, 240), seed=5)
    pose = models.make("lgmd1", preset="published+pose")
    image = models.make("lgmd1", preset="published+image")
    plain = models.make("lgmd1")
    for f, r in zip(frames, turns, strict=True):
        a = pose.step(f, layers=True, rotation=r)
        b = image.step(f, layers=True)
        c = plain.step(f, layers=True)
    err = np.abs(a.layers["P"] - b.layers["P"]).mean()
    assert err < 0.1 * np.abs(c.layers["P"]).mean()
    assert image.front_end.inliers[0] >= 20


def test_brightness_gain_is_found_where_the_light_changes_and_removed():
    frames, _ = turning_scene(2, (72, 96))
    darker = frames[1].astype(np.float32)
    darker[36:] *= 0.8  # the lower half in shade, the upper half (the sky) as it was
    darker = np.clip(darker + 0.5, 0, 255).astype(np.uint8)
    field = brightness_gain(frames[1], darker, None)
    assert field.shape == (72, 96)
    assert np.allclose(field[:24], 1.0, atol=0.01) and np.allclose(field[48:], 0.8, atol=0.01)
    plain, gain = models.make("lgmd1"), models.make("lgmd1", gain=True)
    for f in (frames[1], darker):
        a, b = plain.step(f, layers=True), gain.step(f, layers=True)
    p_plain, p_gain = np.abs(a.layers["P"]), np.abs(b.layers["P"])
    assert p_gain[:24].mean() < 0.1 and p_gain[48:].mean() < 0.1 * p_plain[48:].mean()


def test_rotations_round_trip():
    r = camera_turns(5, 6, degrees=20.0)
    assert np.allclose([rotation_vector(m) for m in rotation_matrix(r)], r, atol=1e-12)
    assert np.allclose(rotation_homography(np.zeros(3), intrinsics(55, 10, 20)), np.eye(3))


def test_specs_name_front_ends():
    assert models.parse_spec("lgmd1+gain+image") == ("lgmd1", "published+image+gain")
    assert models.parse_spec("feedback/paper+imu") == ("feedback", "paper+imu")
    m = models.make("lgmd2", preset="v0.1+pose", n_streams=2)
    assert (m.params.stabilize, m.params.inhibition_filter, m.rotation_key) == (
        "pose", "low-pass", "pose_rotation")
    for bad, match in [("lgmd1+zoom", "'zoom'"), ("lgmd1+image+imu", "at most one"),
                       ("lgmd1/none+image", "unknown preset")]:
        with pytest.raises(ValueError, match=match):
            models.parse_spec(bad)
    with pytest.raises(ValueError, match="sets stabilize already"):
        models.make("lgmd1", preset="published+image", stabilize="imu")


def test_misused_motion_inputs_are_named(clip):
    with pytest.raises(ValueError, match=r"rotation=info\['imu_rotation'\]"):
        models.make("lgmd1", stabilize="imu").step(clip[0])
    with pytest.raises(ValueError, match="needs stabilize='pose' or 'imu'"):
        models.make("lgmd1").step(clip[0], rotation=np.zeros(3))
    with pytest.raises(ValueError, match="estimates its own motion"):
        models.make("lgmd1", stabilize="image").step(clip[0], motion=Motion(np.eye(3)))
    with pytest.raises(ValueError, match="shape"):
        models.make("lgmd1", stabilize="pose", n_streams=2).step(
            np.stack([clip[0]] * 2), rotation=np.zeros(3))
    with pytest.raises(ValueError, match="homography"):
        models.make("lgmd1").step(clip[0], motion=Motion(np.eye(2)))


def test_a_reset_stream_forgets_its_previous_frame(clip):
    """After reset(streams), a stream's front end starts again: it matches a new model."""
    batch = models.make("feedback", stabilize="image", gain=True, n_streams=2)
    for f in clip[:4]:
        batch.step(np.stack([f, f]))
    batch.reset(streams=[1])
    fresh = models.make("feedback", stabilize="image", gain=True)
    for f in clip[4:]:
        out = batch.step(np.stack([f, f]))
        assert out.potential[1] == fresh.step(f).potential


# --- the world's IMU -----------------------------------------------------------------------


def _episode(steps: int, **overrides):
    import gymnasium as gym

    import lgmd_sim  # noqa: F401  (registers the scenarios)

    env = gym.make("lgmd_sim/HandheldApproach-v0", resolution=(72, 96), **overrides)
    try:
        obs, info = env.reset(seed=3)
        out = [(obs, info)]
        for _ in range(steps):
            obs, _r, _te, _tr, info = env.step([1.0, 0.0])
            out.append((obs, info))
    finally:
        env.close()
    return out


@pytest.fixture(scope="module")
def episode():
    return _episode(6)


def test_the_imu_integrates_the_camera_rotation(episode):
    first = episode[0][1]
    assert np.array_equal(first["pose_rotation"], np.zeros(3))
    assert np.array_equal(first["imu_rotation"], np.zeros(3))
    for obs, info in episode[1:]:
        assert np.linalg.norm(info["pose_rotation"]) > 1e-4  # the hand shakes
        assert np.allclose(info["imu_rotation"], info["pose_rotation"], atol=1e-9)
        assert np.array_equal(obs["proprio"][8:], info["imu_rotation"].astype(np.float32))


def test_the_pose_rotation_aligns_consecutive_frames(episode):
    """Frame t-1 warped by the homography of the camera's turn matches frame t better (and
    better than by the opposite turn)."""
    k = intrinsics(55.0, 72, 96)
    error = np.zeros(3)  # unwarped, warped, warped by the opposite turn
    for (prev, _), (obs, info) in itertools.pairwise(episode[1:]):
        a = cv2.cvtColor(prev["frame"], cv2.COLOR_RGB2GRAY).astype(np.float32)
        b = cv2.cvtColor(obs["frame"], cv2.COLOR_RGB2GRAY).astype(np.float32)
        for i, turn in enumerate([None, info["pose_rotation"], -info["pose_rotation"]]):
            seen = a if turn is None else cv2.warpPerspective(
                a, rotation_homography(turn, k), (96, 72))
            error[i] += np.abs(b - seen)[8:-8, 8:-8].mean()
    assert error[1] < 0.7 * min(error[0], error[2])


def test_gyro_noise_and_bias_are_seeded_and_touch_only_the_imu(episode):
    noisy = _episode(6, gyro_noise=0.014, gyro_bias=1.0)
    again = _episode(6, gyro_noise=0.014, gyro_bias=1.0)
    for (obs, info), (nobs, ninfo), (_aobs, ainfo) in zip(episode, noisy, again, strict=True):
        assert np.array_equal(obs["frame"], nobs["frame"])
        assert np.array_equal(info["pose_rotation"], ninfo["pose_rotation"])
        assert np.array_equal(ninfo["imu_rotation"], ainfo["imu_rotation"])
    error = np.degrees(np.linalg.norm(noisy[-1][1]["imu_rotation"]
                                      - noisy[-1][1]["pose_rotation"]))
    assert 1e-4 < error < 0.5  # about 1 deg/s of bias over a 1/30 s frame


# --- the wrappers ----------------------------------------------------------------------------



def test_the_wrapper_needs_the_info_it_names():
    from lgmd_sim.envs.wrappers import LGMDFeatures

    features = LGMDFeatures(1, "lgmd1", preset="published+pose", grid=None)
    with pytest.raises(ValueError, match="pose_rotation from each step's info"):
        features.step(np.zeros((1, 16, 16, 3), np.uint8), np.array([True]))


# --- lgmd-sim detect --stabilize ---------------------------------------------------------------


def test_detect_takes_the_rotation_from_infos():
    from lgmd_sim.detect import detect

    frames, turns = turning_scene(5, (48, 64), seed=8)
    infos = [{"imu_rotation": r} for r in turns]
    d = detect(frames, 30.0, {"a": models.make("lgmd1", preset="published+imu")},
               infos=infos)
    m = models.make("lgmd1", stabilize="imu")
    expected = [m.step(f, rotation=r).potential for f, r in zip(frames, turns, strict=True)]
    assert d.models["a"].potential.tolist() == expected
    with pytest.raises(ValueError, match="need imu_rotation from each frame's info"):
        detect(frames, 30.0, {"a": models.make("lgmd1", preset="published+imu")})


def test_the_fit_at_an_assumed_60_degrees_removes_most_motion_of_cameras_of_40_to_90():
    """The video presets' front end assumes 60 degrees of a camera nobody calibrated: the
    rotation it fits still warps the previous frame onto the next for the fields of view
    real cameras have (measured: 5% of the frame difference is left at 60 degrees, 8% at
    40, 18% at 90, with 1-degree turns)."""
    h, w = 120, 160
    k = intrinsics(60.0, h, w)
    inner = (slice(15, -15), slice(15, -15))  # the borders the warp uncovers
    left = {}
    for fovy in (40.0, 60.0, 90.0):
        frames, _ = turning_scene(12, (h, w), fovy=fovy)
        fit = ImageRotation(60.0)
        residual, moved = [], []
        for t, frame in enumerate(frames):
            rot, _ = fit.update(frame)
            if t:
                warped = cv2.warpPerspective(frames[t - 1].astype(np.float32),
                                             k @ rot @ np.linalg.inv(k), (w, h))
                residual.append(np.abs(warped - frame)[inner].mean())
                moved.append(np.abs(frames[t - 1].astype(np.float32) - frame)[inner].mean())
        left[fovy] = np.mean(residual) / np.mean(moved)
    assert max(left.values()) < 0.25
    assert left[60.0] < min(left[40.0], left[90.0])  # the assumed one fits best


@pytest.mark.parametrize("name", ["feedback", "lgmd2"])
def test_working_height_shows_the_model_a_large_frame_at_the_calibrated_size(name):
    """A video preset's model sees a frame of any size shrunk to its clips' height (area
    average, the width in proportion): the same potentials as the full model fed the
    shrunk frames, front end included; alone or in a batch; smaller frames unchanged."""
    frames, _ = rotating_scene(96, 160, 12, seed=3)
    small = [cv2.resize(f, (80, 48), interpolation=cv2.INTER_AREA) for f in frames]
    front = {"stabilize": "image", "gain": True, "fovy": 60.0}
    shrunk = models.make(name, working_height=48, **front)
    plain = models.make(name, **front)
    got = [shrunk.step(f).potential for f in frames]
    assert got == [plain.step(f).potential for f in small]
    assert shrunk.frame_shape == (48, 80)
    batch = models.make(name, working_height=48, n_streams=2, **front)
    pairs = [batch.step(np.stack([f, f[:, ::-1]])).potential for f in frames]
    assert [p[0] for p in pairs] == got
    shrunk.reset()
    assert [shrunk.step(f).potential for f in small] == got  # no taller than 48: as given


def test_the_gain_grids_median_is_numpys_nanmedian():
    from lgmd_sim.models.stabilize import _nan_median

    rng = np.random.default_rng(5)
    for _ in range(200):
        blocks = rng.random((144, 64), np.float32) * 2
        blocks[rng.random(blocks.shape) < rng.random() * 0.7] = np.nan
        blocks = blocks[np.isfinite(blocks).any(axis=-1)]
        np.testing.assert_array_equal(_nan_median(blocks),
                                      np.nanmedian(blocks, axis=-1).astype(np.float32))
