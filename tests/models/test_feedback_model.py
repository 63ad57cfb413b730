"""The feedback LGMD: parameters, rest, the fast kernel against the per-equation reference,
the feedback loop, and selectivity on the synthetic stimuli."""

import math

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.models.feedback import FeedbackLGMD, delay_weights, spline_coefficients
from lgmd_sim.models.kernels import gaussian_taps
from lgmd_sim.models.reference import make_reference
from lgmd_sim.models.reference.feedback import cardinal_bspline
from lgmd_sim.signals import stimuli

# Parameters under which the loop is active on the stimuli below (D reaches the spline's
# centres), so that the tests exercise Phi and its effect on P_on / P_off. The gain keeps
# the loop's gain per frame below 1, so float32 rounding is not amplified frame by frame.
ACTIVE = {"eta": (10.0, 30.0), "zeta": (0.5, 1.0), "feedback_gain": 300.0}


def _run(model, frames, layers=False):
    outs = [model.step(f, layers=layers) for f in frames]
    return np.array([o.potential for o in outs]), [o.layers for o in outs]


# --- parameters ---------------------------------------------------------------------------


def test_paper_preset_is_table_1_and_the_default():
    p = models.make("feedback").params
    assert (p.beta1, p.beta2, p.sigma1, p.sigma2, p.alpha) == (-0.01, 0.003, 0.1, 0.3, 0.1)
    assert (p.eps1, p.eps2, p.rho, p.eta, p.zeta) == (0.2, 0.2, 1.0, (100.0, 300.0), (0.5, 1.0))
    assert p.threshold == 0.8
    text = models.make("feedback", preset="paper-text").params
    assert (text.beta1, text.beta2) == (0.001, -0.01)
    assert next(iter(FeedbackLGMD.presets)) == "paper"


@pytest.mark.parametrize(
    ("name", "value"),
    [("alpha", -1.0), ("sigma1", 0.0), ("sigma2", float("nan")), ("mu", float("inf")),
     ("rho", -2.0), ("eps1", "0.2"), ("spline_order", 1), ("spline_order", 4.0),
     ("k_mode", "membrane"), ("k", -1), ("delay_taps", 0), ("tv_window", 2.5),
     ("feedback_gain", -1.0), ("eta", (1.0, float("nan"))), ("zeta", 0.5)],
)
def test_invalid_values_are_named(name, value):
    with pytest.raises(ValueError, match=name):
        models.make("feedback", **{name: value})


def test_eta_and_zeta_pair_up():
    with pytest.raises(ValueError, match=r"eta and \.zeta"):
        models.make("feedback", eta=(100.0,), zeta=(0.5, 1.0))
    with pytest.raises(ValueError, match=r"eta and \.zeta"):
        models.make("feedback", eta=(), zeta=())
    p = models.make("feedback", eta=[50, 150, 250], zeta=[1, 1, 1]).params
    assert p.eta == (50.0, 150.0, 250.0) and hash(p)


def test_discretised_filters():
    w = delay_weights(3)
    assert w.sum() == pytest.approx(1.0) and np.all(np.diff(w) < 0)  # Eq. 11, non-increasing
    assert w[1] / w[0] == pytest.approx(math.exp(-3 * math.pi))
    assert w[2] / w[0] < 2**-24  # a third tap is below float32 resolution: default 2 taps
    assert gaussian_taps(0.1) == (1.0,)  # outer taps of 2e-22 dropped
    g = gaussian_taps(0.3)
    assert len(g) == 3 and sum(g) == pytest.approx(1.0) and g[0] == pytest.approx(0.00383, 1e-2)
    assert len(gaussian_taps(1.0)) == 7  # radius ceil(3 sigma)


@pytest.mark.parametrize("order", [2, 3, 4, 5])
def test_spline_forms_agree(order):
    # the kernel's truncated-power form against the reference's Cox-de Boor recursion
    x = np.linspace(-4.0, 4.0, 801)
    c = spline_coefficients(order)
    power = sum(ck * np.maximum(order / 2 - k - np.abs(x), 0.0) ** (order - 1)
                for k, ck in enumerate(c))
    np.testing.assert_allclose(power, cardinal_bspline(np.abs(x) + order / 2, order), atol=1e-12)
    if order == 4:
        assert power.max() == pytest.approx(2 / 3)  # the cubic's peak


# --- rest, batches, layers ----------------------------------------------------------------


@pytest.mark.parametrize("preset", ["paper", "paper-text"])
def test_static_scene_rests_exactly(preset):
    s = stimuli.static(n_frames=12, look=stimuli.Look(background="texture"))
    pot, layers = _run(models.make("feedback", preset=preset), s.frames, layers=True)
    assert np.all(pot == 0.5)
    for name in ("P", "S", "D", "Phi"):
        assert not layers[-1][name].any()


def test_first_frame_of_a_stream_rests():
    frames = stimuli.approaching(still_frames=0).frames
    m = models.make("feedback", **ACTIVE)
    assert m.step(frames[20]).potential == 0.5
    assert m.step(frames[21]).potential > 0.5


def test_batch_with_resets_equals_streams_with_feedback_active():
    looks = [stimuli.Look(polarity=p, background="texture", seed=i)
             for i, p in enumerate(("dark", "light", "dark", "light"))]
    clips = [stimuli.approaching((40, 56), look=look).frames[-20:] for look in looks]
    clips[2] = stimuli.jittered(stimuli.approaching((40, 56)), 1.0, seed=5).frames[-20:]
    batch = models.make("feedback", n_streams=4, k_mode="potential", **ACTIVE)
    singles = [models.make("feedback", k_mode="potential", **ACTIVE) for _ in clips]
    for t in range(20):
        if t in (6, 13):
            batch.reset(streams=[t % 4, 3])
            for i in (t % 4, 3):
                singles[i].reset()
        out = batch.step(np.stack([c[t] for c in clips]), layers=True)
        for i, m in enumerate(singles):
            ref = m.step(clips[i][t], layers=True)
            assert out.potential[i] == ref.potential
            for name in m.layer_names:
                np.testing.assert_array_equal(out.layers[name][i], ref.layers[name])


# --- the fast kernel against the per-equation reference ----------------------------------


CASES = {
    "paper": {},
    "paper-text": {"preset": "paper-text"},
    "active, K constant": ACTIVE,
    "active, K potential": {**ACTIVE, "eta": (100.0, 300.0), "k_mode": "potential"},
    "wide filters, 3 taps, T 3": {"sigma1": 1.0, "sigma2": 2.0, "delay_taps": 3,
                                  "tv_window": 3, **ACTIVE},
    "quadratic spline": {"spline_order": 3, **ACTIVE},
}


@pytest.fixture(scope="module")
def clips() -> dict[str, np.ndarray]:
    shape = (60, 80)
    return {
        "approach": stimuli.approaching(shape, look=stimuli.Look(background="texture")).frames,
        "jittered": stimuli.jittered(
            stimuli.approaching(shape, look=stimuli.Look(polarity="light")), 1.0, seed=2).frames,
        "grating": stimuli.grating(shape, n_frames=15).frames,
    }


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES)
def test_fast_kernel_equals_reference(case, clips):
    kwargs = dict(CASES[case])
    phi_seen = 0.0
    for frames in clips.values():
        fast = models.make("feedback", **kwargs)
        ref = make_reference("feedback", **kwargs)
        pf, lf = _run(fast, frames, layers=True)
        pr, lr = _run(ref, frames, layers=True)
        np.testing.assert_allclose(pf, pr, rtol=0, atol=2e-6)
        for a, b in zip(lf, lr, strict=True):
            np.testing.assert_array_equal(a["P"], b["P"])
            np.testing.assert_allclose(a["S"], b["S"], rtol=1e-4, atol=1e-4)
            np.testing.assert_allclose(a["D"], b["D"], rtol=1e-4, atol=1e-3)
            np.testing.assert_allclose(a["Phi"], b["Phi"], rtol=0, atol=1e-3)
            phi_seen = max(phi_seen, float(b["Phi"].max()))
    if "active" in case or "spline" in case:
        assert phi_seen > 0.1  # the loop really was exercised


@pytest.mark.slow
def test_tiny_frames_with_wide_filters_equal_reference():
    # a filter radius larger than the frame: borders replicate through the whole ring
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 256, (8, 3, 4), dtype=np.uint8)
    kwargs = {"sigma1": 1.5, "sigma2": 0.7, **ACTIVE}
    pf, lf = _run(models.make("feedback", **kwargs), frames, layers=True)
    pr, lr = _run(make_reference("feedback", **kwargs), frames, layers=True)
    np.testing.assert_allclose(pf, pr, rtol=0, atol=2e-6)
    np.testing.assert_allclose(lf[-1]["S"], lr[-1]["S"], rtol=1e-4, atol=1e-4)


# --- the feedback loop --------------------------------------------------------------------


def test_literal_loop_is_silent_when_phi_is_zero():
    # Table 1: the spline terms sit at D = 100 and 300, which these approaches never reach
    # (paper-notes 2): opening the loop changes nothing at all.
    for polarity in ("dark", "light"):
        frames = stimuli.approaching(look=stimuli.Look(polarity=polarity)).frames
        closed, layers = _run(models.make("feedback"), frames, layers=True)
        opened, _ = _run(models.make("feedback", feedback_gain=0.0), frames)
        assert all(not lay["Phi"].any() for lay in layers)
        np.testing.assert_array_equal(closed, opened)


def test_raising_the_gain_changes_the_output():
    frames = stimuli.jittered(stimuli.approaching(look=stimuli.Look(background="texture")), 1.0,
                              seed=1).frames
    opened, _ = _run(models.make("feedback", **{**ACTIVE, "feedback_gain": 0.0}), frames)
    closed, layers = _run(models.make("feedback", **{**ACTIVE, "feedback_gain": 3000.0}),
                          frames, layers=True)
    assert max(float(lay["Phi"].max()) for lay in layers) > 0.3
    # Table 1's signs make it negative feedback: less S, a lower potential
    assert np.abs(closed - opened).max() > 0.01
    assert closed.mean() < opened.mean()


# --- selectivity --------------------------------------------------------------------------


@pytest.mark.parametrize("polarity", ["dark", "light"])
@pytest.mark.parametrize("form", ["square", "disc"])
def test_selectivity_approach_versus_recession_and_translation(polarity, form):
    look = stimuli.Look(polarity=polarity, form=form)
    approach = stimuli.approaching(look=look)
    pot, _ = _run(models.make("feedback"), approach.frames)
    first_alarm = int(np.argmax(pot > 0.8))
    still = 5
    motion = approach.collision_frame - still
    assert pot[first_alarm] > 0.8
    assert still + 0.8 * motion <= first_alarm < approach.collision_frame
    for other in (stimuli.receding(look=look), stimuli.translating(look=look)):
        p, _ = _run(models.make("feedback"), other.frames)
        assert p.max() < 0.72  # clearly below the threshold
        assert p.max() < pot.max() - 0.2
