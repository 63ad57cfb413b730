"""`lgmd-sim calibrate`: the declared objective, a tiny search end to end, and presets
from the data file."""

from __future__ import annotations

import numpy as np
import pytest

from lgmd_sim.calibration import objective as obj


def test_first_crossings_at_every_threshold_at_once():
    p = np.array([0.5, 0.6, 0.55, 0.9, 0.7])
    assert obj.first_crossings(p, np.array([0.5, 0.58, 0.6, 0.85, 0.95])).tolist() == [
        1, 1, 3, 3, 5]


def test_each_kind_is_judged_as_declared():
    jitter = obj.ClipLabel("jitter", 101, 100)  # late window: frames 85..100
    stationary = obj.ClipLabel("stationary", 101, 100)
    near = obj.ClipLabel("near_miss", 101, None)
    ramp = np.linspace(0.5, 0.99, 101)  # crosses 0.8 at frame 62, 0.95 at frame 92
    early, late = np.array([0.8]), np.array([0.95])
    assert obj.hits([jitter], [ramp], early).tolist() == [[False]]  # too early
    assert obj.hits([jitter], [ramp], late).tolist() == [[True]]
    assert obj.hits([stationary], [ramp], early).tolist() == [[True]]
    assert obj.hits([near], [ramp], late).tolist() == [[False]]  # it alarmed: a false alarm
    assert obj.hits([near, jitter], [np.full(101, 0.5)] * 2, late).tolist() == [[True], [False]]
    score, rates = obj.objective([jitter, stationary, near],
                                 obj.hits([jitter, stationary, near], [ramp] * 3, late))
    assert rates == {"jitter": 1.0, "stationary": 1.0, "near_miss": 0.0}
    assert score.tolist() == pytest.approx([2 / 3])
