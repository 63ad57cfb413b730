"""The four baselines (LGMD1, LGMD2, F(ONn), F(OFFp)): oracle, batches, rest, selectivity."""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim import models, stimuli
from lgmd_sim.models.reference import make_reference

BASELINES = ["lgmd1", "lgmd2", "f_on", "f_off"]
SMALL = (40, 56)
# Selectivity set: a 0.2 m square, contrast 0.3, approaching from 3 m at 2 m/s; the same
# object receding from 1.5 to 3 m (the approach's first half, reversed) and crossing the
# view at 3 m at 2 m/s. With the published sigmoid coefficients, nearer or faster motion
# of any kind drives every baseline over the threshold (docs/models.md, "Baselines").
SELECTIVITY = {"shape": (120, 160), "contrast": 0.3}


def run(model: models.LGMDModel, frames: np.ndarray) -> np.ndarray:
    return np.array([model.step(f).potential for f in frames])


def oracle_clips() -> list[np.ndarray]:
    """Clips that drive the models through their whole range, in small frames."""
    app = stimuli.approaching(SMALL, polarity="light", background="texture", contrast=0.5)
    tra = stimuli.jittered(stimuli.translating(SMALL, speed=2.0, still_frames=2), 1.0, seed=1)
    flick = stimuli.flicker(SMALL, background="texture", n_frames=12, still_frames=2)
    grat = stimuli.grating(SMALL, waveform="square", n_frames=10, still_frames=1)
    return [app.frames, tra.frames, flick.frames, grat.frames]


@pytest.mark.parametrize(
    ("name", "params"),
    [
        ("lgmd1", {}),
        ("lgmd1", {"c_sig": 30.0, "coincidence": False, "t_s": 5.37, "w_i": 0.45}),
        ("lgmd1", {"c_sig": 30.0, "t_ffi": 3.0}),
        ("lgmd2", {}),
        ("lgmd2", {"c_sig": 30.0, "fps": 60.0, "carry": 0.3}),
        ("f_on", {"c_sig": 30.0}),
        ("f_off", {"c_sig": 30.0, "ffi_gate": 3.0}),
    ],
)
def test_fast_model_matches_per_equation_reference(name: str, params: dict) -> None:
    # c_sig > 1 keeps the potentials off saturation, where a difference would be hidden
    for clip in oracle_clips():
        fast = models.make(name, **params)
        ref = make_reference(name, **params)
        for frame in clip:
            a = fast.step(frame, layers=True)
            b = ref.step(frame, layers=True)
            assert a.potential == pytest.approx(b.potential, abs=1e-5)
            for k in fast.layer_names:
                # float32 against float64: a cell exactly on a cut (|S| = t_s, G c_de =
                # t_de) may fall either side (and move G of its 3x3 neighbourhood)
                off = ~np.isclose(a.layers[k], b.layers[k], atol=2e-3, rtol=1e-4)
                assert off.mean() <= 5e-3, f"{name} layer {k}: {off.sum()} cells differ"


@pytest.mark.parametrize("name", BASELINES)
def test_batch_equals_separate_streams_with_a_mid_stream_reset(name: str) -> None:
    clips = [
        stimuli.approaching(SMALL, polarity="dark").frames[:30],
        stimuli.jittered(stimuli.translating(SMALL, polarity="light"), 0.5, seed=2).frames[:30],
        stimuli.grating(SMALL, n_frames=29, still_frames=1).frames,
    ]
    restart = stimuli.approaching(SMALL, polarity="light", background="texture").frames[:14]
    clips[1] = np.concatenate([clips[1][:16], restart])  # stream 1 starts anew at frame 16
    batch = models.make(name, c_sig=20.0, n_streams=3)
    single = [models.make(name, c_sig=20.0) for _ in clips]
    for t in range(30):
        if t == 16:
            batch.reset(streams=[1])
            single[1].reset()
        out = batch.step(np.stack([c[t] for c in clips]), layers=t % 10 == 9)
        for i, model in enumerate(single):
            one = model.step(clips[i][t], layers=t % 10 == 9)
            assert out.potential[i] == one.potential, (t, i)
            assert out.alarm[i] == one.alarm
            if out.layers is not None:
                for k in model.layer_names:
                    np.testing.assert_array_equal(out.layers[k][i], one.layers[k])


@pytest.mark.parametrize("name", BASELINES)
def test_a_static_scene_gives_exactly_the_resting_potential(name: str) -> None:
    frames = stimuli.static(SMALL, n_frames=8).frames
    model = models.make(name)
    for frame in frames:
        out = model.step(frame)
        assert out.potential == 0.5 and not out.alarm
    model.reset()
    for frame in frames[:3]:  # float input, and a colour frame
        assert model.step(frame / 255.0).potential == 0.5
    assert model.step(np.repeat(frames[0][..., None], 3, axis=2) / 255.0).potential == 0.5


@pytest.mark.parametrize("name", BASELINES)
def test_uint8_and_float_input_agree(name: str) -> None:
    frames = stimuli.approaching(SMALL, contrast=0.5, background="texture").frames
    a = run(models.make(name, c_sig=20.0), frames)
    b = models.make(name, c_sig=20.0)  # switches from uint8 to float half-way
    mixed = [b.step(f if t < 20 else f / 255.0).potential for t, f in enumerate(frames)]
    np.testing.assert_allclose(mixed, a, atol=1e-6)


@pytest.mark.parametrize("polarity", ["dark", "light"])
@pytest.mark.parametrize("name", BASELINES)
def test_approach_crosses_threshold_late_while_recession_and_translation_stay_low(
    name: str, polarity: str
) -> None:
    kw = {**SELECTIVITY, "polarity": polarity}
    app = stimuli.approaching(**kw)  # 3 m at 2 m/s, after 5 still frames
    rec = stimuli.receding(near_distance=1.5, end_distance=3.0, **kw)
    tra = stimuli.translating(distance=3.0, speed=2.0, **kw)
    k_app = run(models.make(name), app.frames)
    first = int(np.argmax(k_app > 0.8))
    assert k_app[first] > 0.8, f"{name} never crossed: max {k_app.max():.3f}"
    motion = app.collision_frame - 5
    # in the last part of the approach (its second half), and before collision
    assert 5 + motion / 2 < first < app.collision_frame
    assert np.all(k_app[5:5 + motion // 2] < 0.8)
    for other in (rec, tra):
        peak = run(models.make(name), other.frames).max()
        assert peak < 0.75, f"{name}: {other.name} peaks at {peak:.3f}"
        assert k_app.max() - peak > 0.2


def test_lgmd2_answers_a_dark_approach_more_strongly_than_a_light_one() -> None:
    response = {}
    first = {}
    for polarity in ("dark", "light"):
        k = run(models.make("lgmd2"), stimuli.approaching(**SELECTIVITY, polarity=polarity).frames)
        response[polarity] = (k - 0.5).sum()
        first[polarity] = int(np.argmax(k > 0.8))
    assert response["dark"] > 1.2 * response["light"]
    assert first["dark"] < first["light"]


@pytest.mark.parametrize(
    ("name", "gated", "ungated"), [("f_on", "light", "dark"), ("f_off", "dark", "light")]
)
def test_ffi_gates_only_its_own_polarity(name: str, gated: str, ungated: str) -> None:
    # An approaching light object excites ON cells only, a dark one OFF cells only.
    frames = {p: stimuli.approaching(**SELECTIVITY, polarity=p).frames for p in (gated, ungated)}

    def potentials(polarity: str, **params: float) -> np.ndarray:
        return run(models.make(name, **params), frames[polarity])

    np.testing.assert_array_equal(potentials(ungated), potentials(ungated, ffi_gate=0.0))
    with_gate, without = potentials(gated), potentials(gated, ffi_gate=0.0)
    # while the channel's activity is below the gate the model rests, where it would not
    assert np.any((with_gate == 0.5) & (without > 0.6))
    assert np.argmax(with_gate > 0.8) > np.argmax(without > 0.8)


@pytest.mark.parametrize(
    ("name", "params", "field"),
    [
        ("lgmd1", {"w_i": -0.1}, "w_i"),
        ("lgmd1", {"c_sig": 0.0}, "c_sig"),
        ("lgmd1", {"coincidence": "yes"}, "coincidence"),
        ("lgmd1", {"t_ffi": float("nan")}, "t_ffi"),
        ("lgmd2", {"on_weights": (2.0, 0.5)}, "on_weights"),
        ("lgmd2", {"off_delays": (60.0, -1.0, 180.0)}, "off_delays"),
        ("lgmd2", {"fps": 0}, "fps"),
        ("lgmd2", {"carry": 1.5}, "carry"),
        ("f_on", {"ffi_gate": -1.0}, "ffi_gate"),
        ("f_off", {"tau_sfa": float("inf")}, "tau_sfa"),
        ("f_off", {"threshold": 1.2}, "threshold"),
    ],
)
def test_invalid_parameters_raise_a_clear_error(name: str, params: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        models.make(name, **params)


@pytest.mark.parametrize("name", BASELINES)
def test_every_parameter_has_a_source_and_the_layers_have_the_frame_shape(name: str) -> None:
    cls = models.model_class(name)
    assert all(source for _, _, source, _ in cls.Params.describe())
    out = models.make(name).step(np.zeros(SMALL, np.uint8), layers=True)
    assert list(out.layers) == list(cls.layer_names)
    assert all(v.shape == SMALL and v.dtype == np.float32 for v in out.layers.values())
