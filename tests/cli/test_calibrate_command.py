"""`lgmd-sim calibrate` end to end at tiny sizes: the walker's and the video task's presets
written and taken by the models, each task's objective in --help, a bad task refused by
the configuration and the command, and the video page reading the run."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import cli, models
from lgmd_sim.calibration import clips, run, search
from lgmd_sim.calibration import objective as obj

ROOT = Path(__file__).resolve().parents[2]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


def _potentials(out, records, preset: str) -> list[np.ndarray]:
    """LGMD1 at `preset` over the clips of `records` the calibration in `out` stored, each
    from a reset, as the calibration scores a detector."""
    model = models.make("lgmd1", preset=preset)
    potentials = []
    for r in records:
        frames, _ = clips.load_clip(out / "clips", r["key"])
        model.reset()
        potentials.append(np.array([model.step(f).potential for f in frames]))
    return potentials


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
        records = [json.loads(p.read_text()) for p in sorted((out / "records").glob("clip-*"))]
        heldout = [r for r in records if r["key"].endswith("-s100")]
        potentials = _potentials(out, heldout, "calibrated-image")
        at = np.array([stabilized["params"]["threshold"]])
        hit = obj.hits([clips.label(r) for r in heldout], potentials, at)
        score, _ = obj.objective([clips.label(r) for r in heldout], hit)
        assert score[0] == pytest.approx(stabilized["heldout"]["objective"])
        assert search.THRESHOLDS.size > 50
    finally:
        presets._load.cache_clear()


def test_calibrate_help_points_each_task_to_its_objective(capsys):
    with pytest.raises(SystemExit):
        cli.main(["calibrate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "lgmd_sim.calibration.objective" in text and "lgmd_sim.calibration.robot" in text
    assert "The robot: its own calibration, two eyes, two tasks" in text


def test_a_bad_task_is_refused_by_the_config_and_the_command(tmp_path, capsys):
    with pytest.raises(ValueError, match=r"task must be one of .*, got 'rover'"):
        run.CalibrateConfig(task="rover")
    assert cli.main(["calibrate", "--task", "rover", "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert "rover" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "c").exists()


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("video") / "cal"
    assert cli.main(["calibrate", "--task", "video", "--detectors", "lgmd1", "--budget", "2",
                     "--seeds", "1", "--resolution", "small", "--workers", "1",
                     "--no-progress", "--out", str(out)]) == 0
    return out


@pytest.mark.slow
def test_a_tiny_video_calibration_writes_video_presets_that_score_as_calibrated(
        tiny_run, monkeypatch):
    out = tiny_run
    data = json.loads((out / "calibrated.json").read_text())
    entry = data["presets"]["lgmd1"]["video"]
    # the front end, the clips' height (--resolution small: 64 x 64) to work at and the
    # objective's alarm of 4 rising frames
    assert entry["params"] | {"stabilize": "image", "gain": True, "fovy": 60.0,
                              "working_height": 64, "alarm_frames": 4,
                              "alarm_rising": True} == entry["params"]
    assert set(entry["heldout"]) == {"objective", "jitter", "stationary", "near_miss",
                                     "non_looming"}
    assert set(entry["transfer"]) == set(entry["heldout"])  # the other looks' set
    summary = (out / "summary.md").read_text()
    assert "non-looming rejected" in summary and "search / held-out / transfer" in summary
    records = [json.loads(p.read_text()) for p in sorted((out / "records").glob("clip-*"))]
    transfer = [r for r in records if r["key"].endswith("-transfer")]
    assert len(transfer) == len(records) // 3
    moved, _ = clips.load_clip(out / "clips", "Receding-j0-s100-transfer")
    plain, _ = clips.load_clip(out / "clips", "Receding-j0-s100")
    assert moved.shape == plain.shape and not np.array_equal(moved, plain)
    assert {r["kind"] for r in records} == set(obj.VIDEO.parts)
    assert all(r["collision_frame"] is None for r in records if r["kind"] == "non_looming")

    from lgmd_sim.models import presets

    monkeypatch.setattr(presets, "CALIBRATED", out / "calibrated.json")
    presets._load.cache_clear()
    try:
        # the preset on its own (rotation and gain fitted from the frames at 60 degrees)
        # scores on the held-out clips what the calibration scored from stored motions
        heldout = [r for r in records if r["key"].endswith("-s100")]
        assert len(heldout) == len(transfer)
        potentials = _potentials(out, heldout, "video")
        labels = [obj.VIDEO.label(r, {}) for r in heldout]
        score, _ = obj.VIDEO.value(np.array([r["kind"] for r in heldout]),
                                   obj.VIDEO.scores(labels, potentials, search.THRESHOLDS),
                                   slice(None))
        at = int(np.flatnonzero(search.THRESHOLDS == entry["params"]["threshold"])[0])
        assert score[at] == pytest.approx(entry["heldout"]["objective"])
    finally:
        presets._load.cache_clear()


def test_the_video_page_reads_the_run_as_the_calibration_chose(tiny_run):
    """docs/experiments/tools/video_page.py's tables: the run's choice (its clips in the order
    they were scored), and a model's video preset scored as the run scored it."""
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(TOOLS))
        page = importlib.import_module("video_page")
    chosen, clip_sets, _ = page._chosen(tiny_run)
    entry = json.loads((tiny_run / "calibrated.json").read_text())["presets"]["lgmd1"]["video"]
    (c,) = chosen
    assert c["threshold"] == entry["params"]["threshold"]
    for name in ("search", "heldout", "transfer"):
        assert c[name] == pytest.approx(entry[name])
    silence = page.silence_table(chosen, clip_sets)
    assert len(silence) == 3 and silence[2].startswith("| lgmd1+image+gain |")
    fronts = page.front_table(tiny_run, chosen, clip_sets)
    assert fronts[2].endswith(f"| {entry['heldout']['objective']:.3f} / "
                              f"{entry['transfer']['objective']:.3f} |")
