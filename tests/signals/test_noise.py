"""lgmd_sim.signals.noise: the paper's Gaussian and salt-and-pepper noise, extra shake, a real
camera's exposure, sensor noise and compression, seeding."""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim.signals import noise


def _frames(n: int = 6, shape=(60, 80)) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    return [rng.integers(40, 216, shape, dtype=np.uint8) for _ in range(n)]


def test_gaussian_has_the_asked_variance_on_the_unit_scale():
    flat = [np.full((200, 200), 128, np.uint8)]
    (out,) = noise.corrupt(flat, noise.parse("gaussian:0.005"), seed=1)
    assert np.var(out / 255.0 - 128 / 255.0) == pytest.approx(0.005, rel=0.05)


def test_salt_and_pepper_density_and_halves():
    flat = [np.full((300, 300), 128, np.uint8)]
    (out,) = noise.corrupt(flat, noise.parse("saltpepper:0.009"), seed=2)
    black, white = (out == 0).mean(), (out == 255).mean()
    assert black + white == pytest.approx(0.009, rel=0.1)
    assert black == pytest.approx(white, rel=0.25)
    assert ((out == 0) | (out == 255) | (out == 128)).all()


def test_shake_moves_the_image_and_level_zero_is_the_identity():
    frames = _frames(3)
    moved = list(noise.corrupt(frames, noise.parse("shake:2"), seed=0))
    assert all(not np.array_equal(a, b) for a, b in zip(frames, moved, strict=True))
    same = list(noise.corrupt(frames, noise.parse("shake:0,gaussian:0"), seed=0))
    assert all(np.array_equal(a, b) for a, b in zip(frames, same, strict=True))


def test_the_same_seed_and_index_give_the_same_noise_in_any_order():
    frames = _frames(5, (20, 30, 3))
    noises = noise.parse("gaussian:0.003,saltpepper:0.004,shake:1")
    stream = list(noise.corrupt(frames, noises, seed=7))
    assert np.array_equal(noise.apply(frames[3], noises, seed=7, index=3), stream[3])
    again = list(noise.corrupt(frames, noises, seed=7))
    assert all(np.array_equal(a, b) for a, b in zip(stream, again, strict=True))
    other = list(noise.corrupt(frames, noises, seed=8))
    assert not np.array_equal(stream[0], other[0])
    assert stream[0].shape == (20, 30, 3) and stream[0].dtype == np.uint8


def test_exposure_is_one_gain_per_frame_that_drifts_smoothly_with_the_asked_spread():
    flat = [np.full((8, 8), 100, np.uint8)] * 3000
    out = np.array([f.mean() for f in noise.corrupt(flat, noise.parse("exposure:1"), seed=4)])
    log_gain = np.log(out / 100)
    assert np.std(log_gain) == pytest.approx(noise.EXPOSURE_SD, rel=0.35)
    steps = np.abs(np.diff(log_gain))
    assert steps.max() < 0.16 and steps.mean() < 0.3 * np.std(log_gain)  # smooth
    (one,) = noise.corrupt(_frames(1), noise.parse("exposure:2"), seed=4)
    ratio = one / _frames(1)[0].astype(float)
    assert np.ptp(ratio[_frames(1)[0] > 100]) < 0.02  # global: one gain for every pixel


def test_sensor_noise_grows_with_the_signal():
    dark, bright = np.full((300, 300), 20, np.uint8), np.full((300, 300), 230, np.uint8)
    spread = []
    for frame in (dark, bright):
        (out,) = noise.corrupt([frame], noise.parse("sensor:2"), seed=5)
        x = frame[0, 0] / 255.0
        expected = 4 * (noise.SENSOR_SHOT * x + noise.SENSOR_READ ** 2)  # level 2: x 4
        assert np.var(out / 255.0) == pytest.approx(expected, rel=0.15)
        spread.append(np.var(out / 255.0))
    assert spread[1] > 3 * spread[0]


def test_jpeg_is_coarser_at_lower_quality_and_keeps_the_frames_shape():
    rng = np.random.default_rng(1)
    smooth = np.kron(rng.integers(0, 255, (8, 10, 3)), np.ones((8, 8, 1))).astype(np.uint8)
    error = {q: np.abs(noise.apply(smooth, noise.parse(f"jpeg:{q}"), 0, 0).astype(int)
                       - smooth).mean() for q in (10, 50, 95)}
    assert error[10] > error[50] > error[95] > 0
    for shape in ((64, 80), (64, 80, 1), (64, 80, 3)):
        assert noise.apply(np.zeros(shape, np.uint8), noise.parse("jpeg:50"), 0, 0
                           ).shape == shape


def test_blur_smears_edges_and_keeps_the_brightness():
    rng = np.random.default_rng(2)
    sharp = np.kron(rng.integers(0, 2, (12, 16)) * 200 + 20, np.ones((8, 8))).astype(np.uint8)
    def edges(frame: np.ndarray) -> float:  # squared gradients: a smear spreads them
        f = frame.astype(float)
        return float((np.diff(f, axis=0) ** 2).mean() + (np.diff(f, axis=1) ** 2).mean())

    energy = {}
    for level in (0.5, 3.0):
        out = [noise.apply(sharp, noise.parse(f"blur:{level}"), 3, t) for t in range(20)]
        energy[level] = np.mean([edges(o) for o in out])
        assert np.mean([o.mean() for o in out]) == pytest.approx(sharp.mean(), rel=0.02)
    assert energy[3.0] < 0.7 * edges(sharp) and energy[3.0] < energy[0.5]


@pytest.mark.parametrize("spec", ["exposure:1", "sensor:1", "jpeg:40", "blur:1",
                                  "shake:1,exposure:1,sensor:1,blur:1,jpeg:60"])
def test_each_camera_noise_is_seeded_and_any_frame_is_made_alone(spec):
    frames = _frames(6, (24, 32, 3))
    noises = noise.parse(spec)
    stream = list(noise.corrupt(frames, noises, seed=9))
    assert all(np.array_equal(a, b) for a, b in
               zip(stream, noise.corrupt(frames, noises, seed=9), strict=True))
    assert np.array_equal(noise.apply(frames[4], noises, seed=9, index=4), stream[4])
    if spec != "jpeg:40":  # compression draws nothing: the same for every seed
        other = list(noise.corrupt(frames, noises, seed=10))
        assert not all(np.array_equal(a, b) for a, b in zip(stream, other, strict=True))


@pytest.mark.parametrize(("spec", "message"), [
    ("gauss:0.1", "unknown noise 'gauss'"),
    ("gaussian", "write kind:level"),
    ("gaussian:abc", "write kind:level"),
    ("saltpepper:1.5", r"level must be a number in \[0, 1\]"),
    ("shake:-1", "shake: level"),
    ("jpeg:0", r"jpeg: level must be a number in \[1, 100\]"),
    ("exposure:11", "exposure: level"),
])
def test_bad_specs_are_one_line_errors(spec, message):
    with pytest.raises(ValueError, match=message):
        noise.parse(spec)
