"""Metrics: SSIM/ISI (Eq. 21), MpSI (Eq. 22), SI (Eq. 23) and the event metrics."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lgmd_sim.signals import metrics


def _frames(seed: int = 0, shape: tuple[int, ...] = (24, 30)) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    a = rng.integers(0, 256, shape, dtype=np.uint8)
    b = np.clip(a.astype(int) + rng.integers(-40, 41, shape), 0, 255).astype(np.uint8)
    return a, b


def _ssim_by_definition(a: np.ndarray, b: np.ndarray) -> float:
    """Wang et al. (2004) written out: an 11 x 11 Gaussian window at every valid position."""
    g = np.exp(-((np.arange(11) - 5) ** 2) / (2 * 1.5**2))
    w = np.outer(g, g) / np.outer(g, g).sum()
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    x, y = a.astype(float), b.astype(float)
    vals = []
    for i in range(x.shape[0] - 10):
        for j in range(x.shape[1] - 10):
            px, py = x[i:i + 11, j:j + 11], y[i:i + 11, j:j + 11]
            mx, my = (w * px).sum(), (w * py).sum()
            vx, vy = (w * (px - mx) ** 2).sum(), (w * (py - my) ** 2).sum()
            cxy = (w * (px - mx) * (py - my)).sum()
            num = (2 * mx * my + c1) * (2 * cxy + c2)
            vals.append(num / ((mx**2 + my**2 + c1) * (vx + vy + c2)))
    return float(np.mean(vals))


def test_ssim_matches_its_definition():
    a, b = _frames()
    assert metrics.ssim(a, b) == pytest.approx(_ssim_by_definition(a, b), abs=1e-6)
    assert 0 < metrics.ssim(a, b) < 1


def test_ssim_identical_frames_is_one_and_constant_frames_by_hand():
    a, _ = _frames()
    assert metrics.ssim(a, a) == 1.0
    # flat frames: only the luminance term, (2 m1 m2 + C1) / (m1^2 + m2^2 + C1)
    c1 = (0.01 * 255) ** 2
    flat1, flat2 = np.full((20, 20), 100, np.uint8), np.full((20, 20), 120, np.uint8)
    assert metrics.ssim(flat1, flat2) == pytest.approx((24000 + c1) / (24400 + c1))


def test_ssim_colour_float_and_errors():
    a, b = _frames(1, (24, 30, 3))
    grey = lambda f: cv2.cvtColor(f, cv2.COLOR_RGB2GRAY)  # noqa: E731
    assert metrics.ssim(a, b) == metrics.ssim(grey(a), grey(b))
    ga, gb = grey(a), grey(b)
    assert metrics.ssim(ga / 255.0, gb / 255.0) == pytest.approx(metrics.ssim(ga, gb), abs=1e-6)
    with pytest.raises(ValueError, match="sizes differ"):
        metrics.ssim(ga, gb[:-1])
    with pytest.raises(ValueError, match="NaN"):
        metrics.ssim(np.full((20, 20), np.nan), np.zeros((20, 20)))
    with pytest.raises(ValueError, match="both"):
        metrics.ssim(ga, gb / 255.0)


def test_isi_and_series():
    a, b = _frames(2)
    series = metrics.ssim_series([a, a, b])
    assert np.isnan(series[0]) and series[1] == 1.0
    assert series[2] == pytest.approx(metrics.ssim(a, b))
    assert metrics.isi(np.stack([a, a, b])) == pytest.approx((1 + metrics.ssim(a, b)) / 2)
    with pytest.raises(ValueError, match="two frames"):
        metrics.isi([a])
    with pytest.raises(ValueError, match="no frames"):
        metrics.isi([])


def test_mpsi():
    assert metrics.mpsi([0.5, 0.5, 1.0]) == pytest.approx(1.5)
    assert metrics.mpsi([0.6] * 4) == 1.0
    for bad, match in (([], "non-empty"), ([0.5, np.nan], "NaN"), ([0.0, 0.0], "> 0")):
        with pytest.raises(ValueError, match=match):
            metrics.mpsi(bad)


def test_sensitivity_index_and_first_alarm():
    mp = [0.5] * 6 + [0.81, 0.9, 0.7, 0.95]
    s = metrics.sensitivity_index(mp)
    assert (s.si, s.crossed, s.first_alarm, s.n_frames) == (0.7, True, 6, 10)
    assert metrics.sensitivity_index(mp, threshold=0.92).si == 1.0  # crosses on the last frame
    never = metrics.sensitivity_index([0.5, 0.8, 0.79])  # 0.8 itself is not above 0.8
    assert (never.si, never.crossed, never.first_alarm) == (1.0, False, None)
    assert metrics.first_alarm(mp) == 6
    assert metrics.first_alarm(np.array([False, False, True, True])) == 2
    assert metrics.first_alarm([False, False]) is None
    with pytest.raises(ValueError, match="non-empty"):
        metrics.sensitivity_index([])


def test_an_alarm_rule_of_several_frames_needs_the_potential_above_in_each():
    mp = [0.9, 0.5, 0.9, 0.9, 0.5, 0.9, 0.9, 0.9, 0.6]
    rule = metrics.AlarmRule
    assert metrics.first_alarm(mp, 0.8) == 0
    assert metrics.first_alarm(mp, 0.8, rule(2)) == 3  # the frame that completes the run
    assert metrics.first_alarm(mp, 0.8, rule(3)) == 7
    assert metrics.first_alarm(mp, 0.8, rule(4)) is None
    assert metrics.sensitivity_index(mp, 0.8, rule(3)).si == pytest.approx(8 / 9)
    np.testing.assert_array_equal(rule(2).series([0.7, 0.9, 0.8]), [-np.inf, 0.7, 0.8])
    assert rule(2).series([0.9]).tolist() == [-np.inf]  # shorter than the run
    # rising: never falling within the run; a surge that falls back is no alarm
    climb = [0.5, 0.85, 0.95, 0.9, 0.85, 0.9, 0.92, 0.95]
    assert metrics.first_alarm(climb, 0.8, rule(3)) == 3
    assert metrics.first_alarm(climb, 0.8, rule(3, rising=True)) == 6
    np.testing.assert_array_equal(rule(2, rising=True).series([0.7, 0.9, 0.8]),
                                  [-np.inf, 0.7, -np.inf])


def test_evaluate_clip_window_lead_and_outcomes():
    def judged(first, collision=50, fps=10.0):
        alarms = np.zeros(80, bool)
        if first is not None:
            alarms[first:] = True
        return metrics.evaluate_clip(alarms, collision, fps)

    hit = judged(40)  # one second (10 frames) before the collision: inside the window
    assert (hit.outcome, hit.lead_frames, hit.lead_s, hit.window_frames) == ("hit", 10, 1.0, 10)
    assert judged(50).outcome == "hit" and judged(50).lead_frames == 0
    early = judged(39)
    assert (early.outcome, early.lead_frames) == ("miss", 11)
    late = judged(51)
    assert (late.outcome, late.lead_frames, late.lead_s) == ("miss", -1, -0.1)
    none = judged(None)
    assert (none.outcome, none.lead_frames, none.first_alarm) == ("miss", None, None)
    assert judged(3, collision=None).outcome == "false_alarm"
    assert judged(None, collision=None).outcome == "correct_rejection"
    # potentials work as well as alarm flags; the window scales with fps and window_s
    mp = np.r_[np.full(20, 0.5), np.full(5, 0.9)]
    ev = metrics.evaluate_clip(mp, 24, fps=2.0, window_s=2.0)
    assert (ev.outcome, ev.window_frames, ev.lead_frames, ev.lead_s) == ("hit", 4, 4, 2.0)
    with pytest.raises(ValueError, match="fps"):
        metrics.evaluate_clip(mp, 3, fps=0)
    with pytest.raises(ValueError, match="collision_frame"):
        metrics.evaluate_clip(mp, -1, fps=30)


def test_score():
    def ev(outcome, collision):
        return metrics.EventResult(outcome, None, 10 if collision else None, 30, None, None)

    hit, miss = ev("hit", True), ev("miss", True)
    fa, cr = ev("false_alarm", False), ev("correct_rejection", False)
    assert metrics.score([hit, hit, cr]) == 100.0
    assert metrics.score([miss, fa]) == 0.0
    # (1 - (3*1 + 1) / (3*2 + 2)) * 100
    assert metrics.score([hit, miss, fa, cr]) == pytest.approx(50.0)
    # a miss weighs three false alarms: (1 - 3/(3*1 + 3)) * 100 and (1 - 1/(3*1 + 3)) * 100
    assert metrics.score([miss, cr, cr, cr]) == pytest.approx(50.0)
    assert metrics.score([hit, fa, cr, cr]) == pytest.approx(100 * 5 / 6)
    with pytest.raises(ValueError, match="no clips"):
        metrics.score([])
