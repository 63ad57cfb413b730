"""The synthetic stimulus set: shapes, ground truth, determinism, jitter."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from lgmd_sim.signals import metrics, noise, stimuli

SHAPE = (60, 80)


def test_approach_ends_on_collision_and_grows_smoothly():
    s = stimuli.approaching(SHAPE, start_distance=1.0, speed=2.0, fps=30.0, still_frames=4)
    # 1 m at 2 m/s is 15 frames of motion after the 4 still ones; the last is the collision
    assert s.frames.shape == (4 + 15 + 1, *SHAPE)
    assert s.frames.dtype == np.uint8
    assert s.collision_frame == 19 == len(s) - 1
    assert s.fps == 30.0
    # still frames identical, then the dark area grows every frame until it fills the view
    assert all(np.array_equal(s.frames[0], s.frames[t]) for t in range(4))
    dark = (255 - s.frames.astype(float)).sum(axis=(1, 2))
    assert np.all(np.diff(dark[3:]) >= 0) and np.all(np.diff(dark[4:16]) > 0)
    assert s.frames[-1].max() == s.frames[-1].min()  # the object covers the view
    np.testing.assert_allclose(s.angular_size[0], 2 * math.atan(0.1 / 1.0))
    assert s.angular_size[-1] == pytest.approx(math.pi)
    assert np.all(np.diff(s.angular_size) >= 0)


def test_collision_frame_when_distance_is_not_a_whole_number_of_frames():
    s = stimuli.approaching(SHAPE, start_distance=1.0, speed=3.0, fps=10.0, still_frames=2)
    # distances 1, 0.7, 0.4, 0.1, -0.2: the eye is reached between frames, at the 5th
    assert s.collision_frame == 2 + 4 == len(s) - 1


def test_edges_are_anti_aliased():
    s = stimuli.approaching(SHAPE)
    mid = s.frames[len(s) // 2]
    levels = np.unique(mid)
    assert len(levels) > 2  # object, background, and partial coverage between


def test_polarity_and_form():
    dark = stimuli.approaching(SHAPE, look=stimuli.Look(polarity="dark"))
    light = stimuli.approaching(SHAPE, look=stimuli.Look(polarity="light"))
    assert dark.frames[0, 0, 0] > 128 > dark.frames[-1].mean()
    assert light.frames[0, 0, 0] < 128 < light.frames[-1].mean()
    square = stimuli.approaching(SHAPE, start_distance=0.5)
    disc = stimuli.approaching(SHAPE, start_distance=0.5, look=stimuli.Look(form="disc"))
    # the same half-size: a disc covers pi/4 of its bounding square
    area = lambda s: (255 - s.frames[0].astype(float) - (255 - s.frames[0, 0, 0])).sum()  # noqa: E731
    assert area(disc) / area(square) == pytest.approx(math.pi / 4, rel=0.03)


def test_receding_is_a_reversed_approach_and_translating_keeps_size():
    rec = stimuli.receding(SHAPE, near_distance=0.5, end_distance=1.5, speed=2.0, still_frames=3)
    assert rec.collision_frame is None
    app = stimuli.approaching(SHAPE, start_distance=1.5, speed=2.0, still_frames=0)
    # the approach passes 0.5 m after 1 m of motion: 15 frames at 30 fps
    np.testing.assert_array_equal(rec.frames[3:], app.frames[15::-1])
    tr = stimuli.translating(SHAPE, still_frames=2)
    assert tr.collision_frame is None
    assert np.ptp(tr.angular_size) == 0
    dark = tr.frames < 128
    assert not dark[:3].any() and not dark[-1].any()  # enters and leaves the view
    cols = [np.flatnonzero(dark[t].any(axis=0)).mean() for t in range(3, len(tr)) if dark[t].any()]
    assert np.all(np.diff(cols) > 0)  # moving rightwards


def test_rotating_turns_a_square_of_constant_area_without_looming():
    rot = stimuli.rotating(SHAPE, rate=90.0, n_frames=16, still_frames=2,
                           look=stimuli.Look(form="disc"))  # a square whatever the form
    assert rot.collision_frame is None and np.ptp(rot.angular_size) == 0
    assert np.array_equal(rot.frames[0], rot.frames[2])  # still, then turning from 0
    darkness = (255 - rot.frames.astype(float)).sum(axis=(1, 2))
    assert np.ptp(darkness) < 0.02 * darkness.mean()  # its area stays
    assert not np.array_equal(rot.frames[2], rot.frames[5])
    # turned by 45 degrees (15 frames at 90 degrees/s), its corners reach further along
    # the row through the centre
    row = rot.frames[:, SHAPE[0] // 2] < 128
    assert row[2 + 15].sum() > row[2].sum()


def test_static_grating_flicker():
    st = stimuli.static(SHAPE, n_frames=5)
    assert st.frames.shape == (5, *SHAPE)
    assert all(np.array_equal(st.frames[0], f) for f in st.frames)
    g = stimuli.grating(SHAPE, n_frames=6, still_frames=2, waveform="square", orientation=45)
    assert g.frames.shape == (8, *SHAPE) and not np.array_equal(g.frames[2], g.frames[3])
    assert np.array_equal(g.frames[0], g.frames[2])
    f = stimuli.flicker(SHAPE, n_frames=30, still_frames=0, fps=30.0, frequency=1.0)
    means = f.frames.mean(axis=(1, 2))
    assert means.argmax() == 7 and means.argmin() == 22  # a quarter and three quarters of 1 s
    assert np.ptp(f.frames[7]) == 0  # uniform field: the whole field changes together


@pytest.mark.parametrize("make", [
    lambda seed: stimuli.approaching(SHAPE, look=stimuli.Look(background="texture", seed=seed)),
    lambda seed: stimuli.static(SHAPE, look=stimuli.Look(background="texture", seed=seed)),
    lambda seed: stimuli.flicker(SHAPE, background="texture", seed=seed),
    lambda seed: stimuli.jittered(stimuli.approaching(SHAPE), 1.0, seed=seed),
])
def test_deterministic_per_seed(make):
    a, b, c = make(1), make(1), make(2)
    np.testing.assert_array_equal(a.frames, b.frames)
    assert not np.array_equal(a.frames, c.frames)


def test_jitter_level_zero_is_identity_and_more_jitter_is_less_similar():
    s = stimuli.static(SHAPE, n_frames=12)
    same = stimuli.jittered(s, 0.0, seed=5)
    np.testing.assert_array_equal(same.frames, s.frames)
    assert same.collision_frame == s.collision_frame and same.fps == s.fps
    isis = [metrics.isi(stimuli.jittered(s, level, seed=5).frames) for level in (0, 0.5, 1, 2)]
    assert isis[0] == 1.0
    assert all(a > b for a, b in itertools.pairwise(isis))
    shaken = stimuli.jittered(s, 2.0, seed=5).frames
    # replicated borders: no black (or white) band appears at the edges
    assert shaken.min() >= s.frames.min() * 0.5 and shaken.max() <= 255


def test_jitter_is_the_noise_modules_shake():
    s = stimuli.approaching(SHAPE)
    shaken = stimuli.jittered(s, 1.5, seed=4)
    shake = noise.parse("shake:1.5")
    for t in (0, 7, len(s) - 1):
        np.testing.assert_array_equal(shaken.frames[t], noise.apply(s.frames[t], shake, 4, t))


@pytest.mark.parametrize("call, name", [
    (lambda: stimuli.Look(polarity="grey"), "polarity"),
    (lambda: stimuli.Look(form="triangle"), "form"),
    (lambda: stimuli.approaching(SHAPE, speed=0), "speed"),
    (lambda: stimuli.Look(half_size=float("nan")), "half_size"),
    (lambda: stimuli.Look(contrast=1.5), "contrast"),
    (lambda: stimuli.Look(background="noise"), "background"),
    (lambda: stimuli.approaching((60,)), "shape"),
    (lambda: stimuli.Look(seed=-1), "seed"),
    (lambda: stimuli.Look(fov=200), "fov"),
    (lambda: stimuli.approaching(SHAPE, still_frames=-1), "still_frames"),
    (lambda: stimuli.receding(SHAPE, near_distance=2, end_distance=1), "end_distance"),
    (lambda: stimuli.grating(SHAPE, waveform="saw"), "waveform"),
    (lambda: stimuli.flicker(SHAPE, depth=0), "depth"),
    (lambda: stimuli.static(SHAPE, n_frames=0), "n_frames"),
    (lambda: stimuli.rotating(SHAPE, rate=0), "rate"),
    (lambda: stimuli.jittered(stimuli.static(SHAPE), -1), "level"),
])
def test_invalid_arguments_are_named(call, name):
    with pytest.raises(ValueError, match=name):
        call()
