"""The interface every LGMD model shares: names, presets, parameters, frames, streams, batches.

Every test runs on each model of `models.available()` whose module imports, so a new
model is held to the same contract as soon as it exists.
"""


import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.signals import metrics, stimuli


def _importable() -> list[str]:
    names = []
    for name in models.available():
        try:
            models.model_class(name)
        except ImportError:
            continue
        names.append(name)
    return names


MODELS = _importable()
SHAPE = (48, 64)


@pytest.fixture(scope="module")
def clip() -> np.ndarray:
    """A short textured approach: every model responds to it."""
    return stimuli.approaching(SHAPE, still_frames=2,
                               look=stimuli.Look(background="texture", seed=1)).frames[-14:]


def test_feedback_is_available():
    assert "feedback" in MODELS


def test_unknown_model_preset_and_parameter_are_named():
    with pytest.raises(ValueError, match=r"'lgmd9'.*feedback"):
        models.make("lgmd9")
    with pytest.raises(ValueError, match="'fast-ish'"):
        models.make("feedback", preset="fast-ish")
    with pytest.raises(ValueError, match="gamma, zeta2"):
        models.make("feedback", gamma=1.0, zeta2=3)


@pytest.mark.parametrize("name", MODELS)
def test_every_parameter_has_a_default_and_a_source(name):
    cls = models.model_class(name)
    described = cls.Params.describe()
    assert described[0][0] == "threshold"
    for pname, _default, source, _doc in described:
        assert source, f"{name}.{pname} has no source"
    for preset in models.presets_of(name):
        models.make(name, preset=preset)


@pytest.mark.parametrize("name", MODELS)
def test_threshold_is_checked(name):
    for bad in (1.5, float("nan"), "0.8"):
        with pytest.raises(ValueError, match="threshold"):
            models.make(name, threshold=bad)


@pytest.mark.parametrize("name", MODELS)
def test_outputs_streaming_and_batched(name, clip):
    m = models.make(name)
    out = m.step(clip[0])
    assert isinstance(out.potential, float) and isinstance(out.alarm, bool)
    assert out.potential == pytest.approx(0.5) and out.layers is None
    out = m.step(clip[1], layers=True)
    assert 0.5 <= out.potential < 1.0
    assert tuple(out.layers) == m.layer_names
    assert all(v.shape == SHAPE and v.dtype == np.float32 for v in out.layers.values())
    b = models.make(name, n_streams=3)
    out = b.step(np.stack([clip[0]] * 3), layers=True)
    assert out.potential.shape == (3,) and out.alarm.shape == (3,)
    assert all(v.shape == (3, *SHAPE) for v in out.layers.values())


@pytest.mark.parametrize("name", MODELS)
def test_frame_size_is_fixed_per_stream(name, clip):
    m = models.make(name)
    m.step(clip[0])
    with pytest.raises(ValueError, match=r"24x32.*48x64"):
        m.step(clip[1][::2, ::2])
    m.reset()  # a new stream may have another size
    m.step(clip[1][::2, ::2])


@pytest.mark.parametrize("name", MODELS)
def test_bad_frames_are_rejected(name, clip):
    m = models.make(name)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        m.step(clip[0] / 100.0)
    with pytest.raises(ValueError, match="NaN"):
        m.step(np.full(SHAPE, np.nan))
    with pytest.raises(ValueError, match="int64"):
        m.step(clip[0].astype(np.int64))
    with pytest.raises(ValueError, match="shape"):
        m.step(clip[0][None, None])
    with pytest.raises(ValueError, match="n_streams"):
        models.make(name, n_streams=0)
    with pytest.raises(ValueError, match=r"expected 2 frames.*got 3"):
        models.make(name, n_streams=2).step(clip[:3])
    with pytest.raises(ValueError, match="batched"):
        m.reset(streams=[0])


@pytest.mark.parametrize("name", MODELS)
def test_grey_colour_uint8_and_float_frames_agree(name, clip):
    grey = models.make(name)
    colour = models.make(name)
    floats = models.make(name)
    peak = 0.5
    for frame in clip:
        g = grey.step(frame).potential
        c = colour.step(np.repeat(frame[..., None], 3, axis=2)).potential
        f = floats.step(frame / 255.0).potential
        assert c == g  # equal RGB channels give the same luma exactly
        assert f == pytest.approx(g, abs=1e-6)
        peak = max(peak, g)
    assert peak > 0.6  # the clip did drive the model


@pytest.mark.parametrize("name", MODELS)
def test_batch_equals_separate_streams_with_a_reset(name, clip):
    frames = [clip, clip[:, ::-1], np.ascontiguousarray(clip[:, :, ::-1])]
    batch = models.make(name, n_streams=3)
    singles = [models.make(name) for _ in frames]
    for t in range(len(clip)):
        if t == 7:  # stream 1 starts again
            batch.reset(streams=[1])
            singles[1].reset()
        out = batch.step(np.stack([f[t] for f in frames]), layers=True)
        for i, m in enumerate(singles):
            ref = m.step(frames[i][t], layers=True)
            assert out.potential[i] == ref.potential
            for layer in m.layer_names:
                np.testing.assert_array_equal(out.layers[layer][i], ref.layers[layer])


@pytest.mark.parametrize("name", MODELS)
@pytest.mark.parametrize("rising", [False, True])
def test_an_alarm_follows_the_models_alarm_rule(name, clip, rising):
    """alarm_frames=k (and alarm_rising): a stream alarms once its potential has been
    above the threshold k frames running (never falling), as metrics.AlarmRule reads a
    series; each stream of a batch counts its own, and a reset starts it again."""
    plain = models.make(name)
    mp = np.array([plain.step(f).potential for f in clip])
    threshold = float(np.clip(np.median(mp), 0.5, 1.0))
    k = 3
    model = models.make(name, threshold=threshold, alarm_frames=k, alarm_rising=rising)
    assert model.alarm_rule == metrics.AlarmRule(k, rising)
    alarms = np.array([model.step(f).alarm for f in clip])
    expected = metrics.AlarmRule(k, rising).series(mp) > threshold
    np.testing.assert_array_equal(alarms, expected)
    assert (mp > threshold).sum() > expected.sum()  # some frames above it raise no alarm
    batch = models.make(name, threshold=threshold, alarm_frames=k, alarm_rising=rising,
                        n_streams=2)
    got = []
    for t, f in enumerate(clip):
        if t == 5:
            batch.reset([1])
        got.append(batch.step(np.stack([f, clip[t - 5] if t >= 5 else f])).alarm)
    np.testing.assert_array_equal(np.array(got)[:, 0], expected)
    np.testing.assert_array_equal(np.array(got)[5:, 1], expected[:len(clip) - 5])
