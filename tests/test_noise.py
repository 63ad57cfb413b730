"""lgmd_sim.noise: the paper's Gaussian and salt-and-pepper noise, extra shake, seeding."""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim import noise


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


@pytest.mark.parametrize(("spec", "message"), [
    ("gauss:0.1", "unknown noise 'gauss'"),
    ("gaussian", "write kind:level"),
    ("gaussian:abc", "write kind:level"),
    ("saltpepper:1.5", r"level must be a number in \[0, 1\]"),
    ("shake:-1", "shake: level"),
])
def test_bad_specs_are_one_line_errors(spec, message):
    with pytest.raises(ValueError, match=message):
        noise.parse(spec)
