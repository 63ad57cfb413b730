"""The four baselines (LGMD1, LGMD2, F(ONn), F(OFFp)): the per-equation oracle for every
switch, batches, rest, selectivity, and what each switch does.

The ``published`` presets against ports of the published code: test_published_baselines.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.models.lgmd2 import frame_interval
from lgmd_sim.models.reference import make_reference
from lgmd_sim.signals import stimuli

BASELINES = ["lgmd1", "lgmd2", "f_on", "f_off"]
#: (model, preset) for every preset of every baseline.
# Presets whose front end reads the camera's rotation from the environment (imu, pose)
# need it every step: these frame-only checks leave them to tests/models/test_stabilize.py and
# tests/models/test_sectors.py, which give it.
PRESETS = [(n, p) for n in BASELINES for p, values in models.presets_of(n).items()
           if values.get("stabilize", "none") not in ("imu", "pose")]
SMALL = (40, 56)
# Selectivity set: a 0.2 m square, contrast 0.3, approaching from 3 m at 2 m/s; the same
# object receding from 1.5 to 3 m (the approach's first half, reversed) and crossing the
# view at 3 m at 2 m/s. With the published sigmoid coefficients, nearer or faster motion
# of any kind drives every baseline over the threshold (docs/reference/models.md, "Baselines").
SELECTIVITY_SHAPE = (120, 160)
SELECTIVITY = stimuli.Look(contrast=0.3)


def run(model: models.LGMDModel, frames: np.ndarray) -> np.ndarray:
    return np.array([model.step(f).potential for f in frames])


def oracle_clips() -> list[np.ndarray]:
    """Clips that drive the models through their whole range, in small frames."""
    textured = stimuli.Look(background="texture", contrast=0.5)
    app = stimuli.approaching(SMALL, look=textured.replace(polarity="light"))
    dark = stimuli.approaching(SMALL, look=textured)
    tra = stimuli.jittered(stimuli.translating(SMALL, speed=2.0, still_frames=2), 1.0, seed=1)
    shake = stimuli.jittered(
        stimuli.approaching(SMALL, look=stimuli.Look(background="texture")), 2.0, seed=2)
    flick = stimuli.flicker(SMALL, background="texture", n_frames=12, still_frames=2)
    grat = stimuli.grating(SMALL, waveform="square", n_frames=10, still_frames=1)
    return [app.frames, dark.frames[-25:], tra.frames, shake.frames[:25], flick.frames,
            grat.frames]


# Every preset, and every value of every switch, against the per-equation reference. A
# large c_sig keeps the potentials off saturation, where a difference would be hidden. The
# reference has no front end: a preset with one (calibrated-image, video) is compared
# without it (tests/models/test_stabilize.py checks the front ends).
NO_FRONT_END = {"stabilize": "none", "gain": False}
SWITCHED = [
    *[(n, p, {"c_sig": 30.0, **{k: v for k, v in NO_FRONT_END.items()
                                if k in models.presets_of(n)[p]}}) for n, p in PRESETS],
    ("lgmd1", "published", {}),
    ("lgmd1", "v0.1", {"c_sig": 30.0, "coincidence": False, "t_s": 5.37, "w_i": 0.45}),
    ("lgmd1", "v0.1", {"c_sig": 30.0, "t_ffi": 3.0, "border": "zero"}),
    ("lgmd1", "lgmd-single", {"c_sig": 300.0, "t_s_rule": "abs", "border": "reflect"}),
    ("lgmd1", "published", {"c_sig": 30.0, "persistence": "decaying", "border": "interior",
                            "t_s": 10.37}),
    ("lgmd1", "plgmd", {"c_sig": 30.0, "persistence_weights": (0.3, 0.2),
                        "g_layer": False}),
    ("lgmd2", "published", {}),
    ("lgmd2", "v0.1", {"c_sig": 30.0, "fps": 60.0, "carry": 0.3}),
    ("lgmd2", "published", {"c_sig": 30.0, "pm_filter": "two-tap", "pm_weights": "per-channel",
                            "border": "reflect", "on_weights": (0.5, 0.25, 0.125)}),
    ("lgmd2", "published", {"c_sig": 30.0, "ffi_channels": "on", "ffi_gate": 0.5,
                            "global_ffi_base": 2.0, "persistence": "constant",
                            "border": "zero", "dt": 40.0}),
    ("lgmd2", "v0.1", {"c_sig": 30.0, "ffi_channels": "both", "ffi_gate": 0.8,
                       "sfa_rise": "decay", "border": "interior"}),
    ("f_on", "published", {"c_sig": 30.0, "pm_off_uses_on_mean": True}),
    ("f_on", "published", {"c_sig": 30.0, "ffi_gate": 0.3, "onoff_product": 0.5,
                           "on_weights": (0.5, 0.25, 0.125), "ffi_gates_history": False}),
    ("f_off", "v0.1", {"c_sig": 30.0, "ffi_gate": 3.0}),
    ("f_off", "v0.1", {"c_sig": 30.0, "ffi_gate": 0.5, "ffi_gates_history": True,
                       "pm_filter": "two-tap", "global_ffi_base": 3.0}),
]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "preset", "params"), SWITCHED)
def test_fast_model_matches_per_equation_reference(name: str, preset: str, params: dict) -> None:
    for clip in oracle_clips():
        fast = models.make(name, preset=preset, **params)
        ref = make_reference(name, preset=preset, **params)
        for frame in clip:
            a = fast.step(frame, layers=True)
            b = ref.step(frame, layers=True)
            assert a.potential == pytest.approx(b.potential, abs=1e-5)
            for k in fast.layer_names:
                # float32 against float64: a cell exactly on a cut (|S| = t_s, G c_de =
                # t_de) may fall either side (and move G of its 3x3 neighbourhood)
                off = ~np.isclose(a.layers[k], b.layers[k], atol=2e-3, rtol=1e-4)
                assert off.mean() <= 5e-3, f"{name} layer {k}: {off.sum()} cells differ"


@pytest.mark.slow
@pytest.mark.parametrize(("name", "preset"), PRESETS)
def test_batch_equals_separate_streams_with_a_mid_stream_reset(name: str, preset: str) -> None:
    clips = [
        stimuli.approaching(SMALL, look=stimuli.Look(polarity="dark")).frames[:30],
        stimuli.jittered(stimuli.translating(SMALL, look=stimuli.Look(polarity="light")), 0.5,
                         seed=2).frames[:30],
        stimuli.grating(SMALL, n_frames=29, still_frames=1).frames,
    ]
    restart = stimuli.approaching(
        SMALL, look=stimuli.Look(polarity="light", background="texture")).frames[:14]
    clips[1] = np.concatenate([clips[1][:16], restart])  # stream 1 starts anew at frame 16
    batch = models.make(name, preset=preset, c_sig=20.0, n_streams=3)
    single = [models.make(name, preset=preset, c_sig=20.0) for _ in clips]
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


@pytest.mark.slow
@pytest.mark.parametrize(("name", "preset"), PRESETS)
def test_a_static_scene_gives_exactly_the_resting_potential(name: str, preset: str) -> None:
    frames = stimuli.static(SMALL, n_frames=8).frames
    model = models.make(name, preset=preset)
    for frame in frames:
        out = model.step(frame)
        assert out.potential == 0.5 and not out.alarm
    model.reset()
    for frame in frames[:3]:  # float input, and a colour frame
        assert model.step(frame / 255.0).potential == 0.5
    assert model.step(np.repeat(frames[0][..., None], 3, axis=2) / 255.0).potential == 0.5


@pytest.mark.slow
@pytest.mark.parametrize(("name", "preset"), PRESETS)
def test_uint8_and_float_input_agree(name: str, preset: str) -> None:
    frames = stimuli.approaching(SMALL, look=stimuli.Look(contrast=0.5,
                                                          background="texture")).frames
    a = run(models.make(name, preset=preset, c_sig=20.0), frames)
    b = models.make(name, preset=preset, c_sig=20.0)  # switches from uint8 to float half-way
    mixed = [b.step(f if t < 20 else f / 255.0).potential for t, f in enumerate(frames)]
    np.testing.assert_allclose(mixed, a, atol=1e-6)


# --- selectivity and polarity -------------------------------------------------------------

#: (model, preset, polarity) whose approach crosses the threshold late, and the cases that
#: stay at rest: the published LGMD2 and oLGMD see no light approaching object at all.
CROSSING = [(n, p, pol) for n in BASELINES for p in ("published", "v0.1")
            for pol in ("dark", "light") if not (n != "lgmd1" and p == "published"
                                                  and pol == "light")]
RESTING = [(n, "published", "light") for n in ("lgmd2", "f_on", "f_off")]


@pytest.mark.parametrize(("name", "preset", "polarity"), CROSSING)
def test_approach_crosses_threshold_late_while_recession_and_translation_stay_low(
    name: str, preset: str, polarity: str
) -> None:
    look = SELECTIVITY.replace(polarity=polarity)
    app = stimuli.approaching(SELECTIVITY_SHAPE, look=look)  # 3 m at 2 m/s, after 5 still frames
    rec = stimuli.receding(SELECTIVITY_SHAPE, near_distance=1.5, end_distance=3.0, look=look)
    tra = stimuli.translating(SELECTIVITY_SHAPE, distance=3.0, speed=2.0, look=look)
    k_app = run(models.make(name, preset=preset), app.frames)
    first = int(np.argmax(k_app > 0.8))
    assert k_app[first] > 0.8, f"{name} never crossed: max {k_app.max():.3f}"
    motion = app.collision_frame - 5
    # in the last part of the approach (its second half), and before collision
    assert 5 + motion / 2 < first < app.collision_frame
    assert np.all(k_app[5:5 + motion // 2] < 0.8)
    for other in (rec, tra):
        peak = run(models.make(name, preset=preset), other.frames).max()
        assert peak < 0.75, f"{name}: {other.name} peaks at {peak:.3f}"
        assert k_app.max() - peak > 0.2


@pytest.mark.parametrize(("name", "preset", "polarity"), RESTING)
def test_published_on_off_models_stay_at_rest_on_a_light_approach(
    name: str, preset: str, polarity: str
) -> None:
    for shape, look in ((SELECTIVITY_SHAPE, SELECTIVITY),
                        (SMALL, stimuli.Look(contrast=0.8, background="texture"))):
        k = run(models.make(name, preset=preset),
                stimuli.approaching(shape, look=look.replace(polarity=polarity)).frames)
        assert k.max() < 0.52, f"{name}: peak {k.max():.3f}"
        dark = run(models.make(name, preset=preset),
                   stimuli.approaching(shape, look=look.replace(polarity="dark")).frames)
        assert dark.max() > 0.8


def test_two_frame_inhibition_silences_the_on_channel_of_lgmd2() -> None:
    # The centre weight 2 times a = 33 / 48 exceeds 1: I_on >= 1.375 ON(t), so S_on = 0.
    frames = stimuli.approaching(SMALL, look=stimuli.Look(polarity="light",
                                                          background="texture")).frames
    for params, silent in (({}, True), ({"inhibition_filter": "low-pass"}, False)):
        model = models.make("lgmd2", **params)
        s = np.stack([model.step(f, layers=True).layers["S"] for f in frames])
        assert (s.max() == 0.0) == silent
        assert s.max() > 10.0 or silent


def test_lgmd2_answers_a_dark_approach_more_strongly_than_a_light_one() -> None:
    for preset, ratio in (("published", np.inf), ("v0.1", 1.2)):
        response = {}
        first = {}
        for polarity in ("dark", "light"):
            k = run(models.make("lgmd2", preset=preset), stimuli.approaching(
                SELECTIVITY_SHAPE, look=SELECTIVITY.replace(polarity=polarity)).frames)
            response[polarity] = (k - 0.5).sum()
            first[polarity] = int(np.argmax(k > 0.8)) if (k > 0.8).any() else len(k)
        assert response["light"] == 0.0 if ratio == np.inf else (
            response["dark"] > ratio * response["light"])
        assert first["dark"] < first["light"]


def test_published_sfa_scales_a_rise_by_its_decay() -> None:
    frames = stimuli.approaching(SMALL, look=stimuli.Look(contrast=0.8)).frames
    decay = 800.0 / 833.0  # tau_sfa / (tau_sfa + dt), dt = 1000 // 30 = 33 ms
    assert frame_interval(models.make("lgmd2").params) == 33.0
    assert frame_interval(models.make("lgmd2", fps=60.0).params) == 16.0
    assert frame_interval(models.make("lgmd2", preset="v0.1").params) == pytest.approx(100 / 3)
    assert frame_interval(models.make("f_on").params) == 53.0
    published = run(models.make("lgmd2"), frames)
    follow = run(models.make("lgmd2", sfa_rise="follow"), frames)
    assert published.max() <= decay + 1e-12 and follow.max() > 0.99
    assert published.max() == pytest.approx(decay, abs=1e-3)  # K saturates, the output not


def test_global_ffi_holds_k_at_rest_under_whole_field_change() -> None:
    frames = stimuli.jittered(
        stimuli.approaching(SMALL, look=stimuli.Look(background="texture", contrast=0.8)), 2.0,
        seed=2).frames
    on = run(models.make("f_off"), frames)
    off = run(models.make("f_off", global_ffi_base=None), frames)
    rested = (on == 0.5) & (off > 0.7)
    assert rested.sum() >= 3, "the global FFI suppressed nothing"
    assert np.all(on <= off + 1e-12)


def test_luminance_persistence_carries_half_of_the_last_two_differences() -> None:
    frames = np.zeros((7, 8, 8), np.uint8)
    frames[2:] = 40  # one step of +40 grey levels at frame 2
    for preset, expected in (("plgmd", [0, 0, 40, 20, 30, 25, 27.5]),
                             ("published", [0, 0, 40, 0, 0, 0, 0])):
        model = models.make("lgmd1", preset=preset)
        p = [model.step(f, layers=True).layers["P"][4, 4] for f in frames]
        np.testing.assert_allclose(p, expected)
    model = models.make("f_on")  # decaying: 1 / (1 + exp(k)), 1 / (1 + exp(k - 1))
    p = [model.step(f, layers=True).layers["P"][4, 4] for f in frames]
    c1 = 1.0 / (1.0 + np.exp(3.0))
    assert p[2] == 40.0 and p[3] == pytest.approx(40.0 * c1, rel=1e-6)


@pytest.mark.parametrize("border", ["replicate", "reflect", "zero", "interior"])
def test_border_rules_change_only_the_frame_edge(border: str) -> None:
    # about 2 pixels of shake a frame drives S at the edge; at level 2 S is silent in all
    # but 2 of the 51 frames, leaving the border rules nothing to differ on
    frames = stimuli.jittered(stimuli.approaching(SMALL, look=stimuli.Look(background="texture")),
                              1.0, seed=2).frames
    a = models.make("lgmd2", border=border)
    b = models.make("lgmd2", border="replicate")
    sa = np.stack([a.step(f, layers=True).layers["S"] for f in frames])
    sb = np.stack([b.step(f, layers=True).layers["S"] for f in frames])
    # S of the cells 2 or more pixels in (their 3x3 inputs inside the frame) is the same;
    # the potential differs through the edge cells and the G layer
    np.testing.assert_array_equal(sa[:, 2:-2, 2:-2], sb[:, 2:-2, 2:-2])
    if border == "interior":
        assert not sa[:, [0, -1]].any() and not sa[:, :, [0, -1]].any()
    if border != "replicate":
        assert not np.array_equal(sa, sb)


def test_lgmd_single_drops_every_s_below_ts_and_has_no_g_layer() -> None:
    frames = stimuli.approaching(SELECTIVITY_SHAPE,
                                 look=stimuli.Look(polarity="dark", contrast=0.8)).frames
    model = models.make("lgmd1", preset="lgmd-single")
    n_cells = frames[0].size
    for f in frames[30:]:
        out = model.step(f, layers=True)
        s = out.layers["S"]
        assert s.min() >= 0.0 and (s[s != 0] >= 30.0).all()
        assert not out.layers["G"].any()
        if out.potential != 0.5:  # not held by the FFI
            k = 1.0 / (1.0 + np.exp(-s.astype(np.float64).sum() / n_cells))
            assert out.potential == pytest.approx(k, abs=1e-6)


@pytest.mark.parametrize(
    ("name", "gated", "ungated"), [("f_on", "light", "dark"), ("f_off", "dark", "light")]
)
def test_v01_ffi_gates_only_its_own_polarity(name: str, gated: str, ungated: str) -> None:
    # An approaching light object excites ON cells only, a dark one OFF cells only.
    frames = {p: stimuli.approaching(SELECTIVITY_SHAPE, look=SELECTIVITY.replace(polarity=p))
              .frames for p in (gated, ungated)}

    def potentials(polarity: str, **params: float) -> np.ndarray:
        return run(models.make(name, preset="v0.1", **params), frames[polarity])

    np.testing.assert_array_equal(potentials(ungated), potentials(ungated, ffi_gate=0.0))
    with_gate, without = potentials(gated), potentials(gated, ffi_gate=0.0)
    # while the channel's activity is below the gate the model rests, where it would not
    assert np.any((with_gate == 0.5) & (without > 0.6))
    assert np.argmax(with_gate > 0.8) > np.argmax(without > 0.8)


def test_published_f_on_and_f_off_are_the_one_published_model() -> None:
    frames = stimuli.jittered(stimuli.approaching(SMALL, look=stimuli.Look(background="texture")),
                              1.0, seed=4)
    np.testing.assert_array_equal(run(models.make("f_on"), frames.frames),
                                  run(models.make("f_off"), frames.frames))
    assert models.make("f_on").params.ffi_channels == "both"


@pytest.mark.parametrize(
    ("name", "params", "field"),
    [
        ("lgmd1", {"w_i": -0.1}, "w_i"),
        ("lgmd1", {"c_sig": 0.0}, "c_sig"),
        ("lgmd1", {"coincidence": "yes"}, "coincidence"),
        ("lgmd1", {"t_ffi": float("nan")}, "t_ffi"),
        ("lgmd1", {"t_s_rule": "both"}, "t_s_rule"),
        ("lgmd1", {"border": "wrap"}, "border"),
        ("lgmd1", {"persistence": "always"}, "persistence"),
        ("lgmd1", {"persistence_weights": (0.5,)}, "persistence_weights"),
        ("lgmd1", {"g_layer": 1}, "g_layer"),
        ("lgmd2", {"on_weights": (2.0, 0.5)}, "on_weights"),
        ("lgmd2", {"off_delays": (60.0, -1.0, 180.0)}, "off_delays"),
        ("lgmd2", {"fps": 0}, "fps"),
        ("lgmd2", {"dt": -33.0}, "dt"),
        ("lgmd2", {"carry": 1.5}, "carry"),
        ("lgmd2", {"inhibition_filter": "current"}, "inhibition_filter"),
        ("lgmd2", {"pm_filter": "fir"}, "pm_filter"),
        ("lgmd2", {"pm_weights": "channel"}, "pm_weights"),
        ("lgmd2", {"sfa_rise": "hold"}, "sfa_rise"),
        ("lgmd2", {"ffi_channels": "all"}, "ffi_channels"),
        ("f_on", {"ffi_gate": -1.0}, "ffi_gate"),
        ("f_on", {"global_ffi_base": -10.0}, "global_ffi_base"),
        ("f_on", {"pm_off_uses_on_mean": "no"}, "pm_off_uses_on_mean"),
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
    assert next(iter(cls.presets)) == "published"
    assert all(source for _, _, source, _ in cls.Params.describe())
    out = models.make(name).step(np.zeros(SMALL, np.uint8), layers=True)
    assert list(out.layers) == list(cls.layer_names)
    assert all(v.shape == SMALL and v.dtype == np.float32 for v in out.layers.values())
