"""`lgmd-sim calibrate`: the declared objective, a tiny search end to end, and presets
from the data file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lgmd_sim import cli, models
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


@pytest.mark.slow
def test_a_tiny_calibration_writes_presets_that_models_take(tmp_path, monkeypatch):
    out = tmp_path / "cal"
    assert cli.main(["calibrate", "--detectors", "lgmd1,feedback-open-loop,lgmd1+image",
                     "--budget", "2", "--seeds", "1", "--resolution", "small",
                     "--workers", "1", "--no-progress", "--out", str(out)]) == 0
    data = json.loads((out / "calibrated.json").read_text())
    assert "lgmd-sim calibrate" in data["command"] and data["budget"] == 2
    entry = data["presets"]["lgmd1"]["calibrated"]
    assert entry["from"] == "published" and 0.5 < entry["params"]["threshold"] < 1
    assert set(entry["heldout"]) == {"objective", "jitter", "stationary", "near_miss"}
    assert "calibrated-open-loop" in data["presets"]["feedback"]
    stabilized = data["presets"]["lgmd1"]["calibrated-image"]
    assert stabilized["params"]["stabilize"] == "image"
    assert (out / "calibration.png").stat().st_size > 10_000
    # the data file makes them presets of the models
    from lgmd_sim.models import presets

    monkeypatch.setattr(presets, "CALIBRATED", out / "calibrated.json")
    presets._load.cache_clear()
    try:
        m = models.make("lgmd1", preset="calibrated")
        assert m.params.threshold == entry["params"]["threshold"]
        loop = models.make("feedback", preset="calibrated-open-loop")
        assert loop.params.feedback_gain == 0.0
        # the stabilized preset, run on its own, scores what the calibration scored
        from lgmd_sim.calibration import clips, search

        records = [json.loads(p.read_text()) for p in sorted((out / "records").glob("clip-*"))]
        heldout = [r for r in records if r["key"].endswith("-s100")]
        model = models.make("lgmd1", preset="calibrated-image")
        potentials = []
        for r in heldout:
            frames, _ = clips.load_clip(out / "clips", r["key"])
            model.reset()
            potentials.append(np.array([model.step(f).potential for f in frames]))
        at = np.array([stabilized["params"]["threshold"]])
        hit = obj.hits([clips.label(r) for r in heldout], potentials, at)
        score, _ = obj.objective([clips.label(r) for r in heldout], hit)
        assert score[0] == pytest.approx(stabilized["heldout"]["objective"])
        assert search.THRESHOLDS.size > 50
    finally:
        presets._load.cache_clear()
