"""The video calibration task (`lgmd-sim calibrate --task video`): the walker's clips and
synthetic stimuli that do not loom, with a real camera's noise; every detector with the
front end a video allows; presets named `video` that score, run on their own, what the
calibration scored."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import cli, models
from lgmd_sim.calibration import clips, search
from lgmd_sim.calibration import objective as obj
from lgmd_sim.calibration.run import TASKS, CalibrateConfig
from lgmd_sim.signals.metrics import AlarmRule

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


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
        model = models.make("lgmd1", preset="video")
        potentials = []
        for r in heldout:
            frames, _ = clips.load_clip(out / "clips", r["key"])
            model.reset()
            potentials.append(np.array([model.step(f).potential for f in frames]))
        labels = [obj.VIDEO.label(r, {}) for r in heldout]
        score, _ = obj.VIDEO.value(np.array([r["kind"] for r in heldout]),
                                   obj.VIDEO.scores(labels, potentials, search.THRESHOLDS),
                                   slice(None))
        at = int(np.flatnonzero(search.THRESHOLDS == entry["params"]["threshold"])[0])
        assert score[at] == pytest.approx(entry["heldout"]["objective"])
    finally:
        presets._load.cache_clear()


def test_a_stimulus_clip_is_seeded_noisy_and_keeps_its_gains(tmp_path):
    spec = clips.ClipSpec("non_looming", "Translating", 1.0, 7)
    task = TASKS["video"]
    kwargs = {"resolution": "small", "fronts": task.fronts, "fovy": task.fovy}
    own = task.looks[""]
    for name, looks in (("a", own), ("b", own), ("clean", clips.Looks())):
        (tmp_path / name).mkdir()
        record = clips.record_clip(spec, str(tmp_path / name), looks=looks, **kwargs)
    assert record == {"kind": "non_looming", "frames": record["frames"], "collision_frame": None}
    a, b, clean = (clips.load_clip(tmp_path / n, spec.key)[0] for n in ("a", "b", "clean"))
    assert np.array_equal(a, b) and not np.array_equal(a, clean)
    gains = clips.load_gains(tmp_path / "a", spec.key, "image+gain")
    assert gains.shape[0] == len(a) and (gains[0] == 1).all() and not (gains[1:] == 1).all()
    assert clips.load_gains(tmp_path / "a", spec.key, "image") is None


def test_a_video_clip_of_a_scene_draws_its_cameras_field_of_view(tmp_path):
    fovy = []
    for seed in (3, 4):
        spec = clips.ClipSpec("near_miss", "PassBy", 0.0, seed)
        clips.record_clip(spec, str(tmp_path), "small", fronts=("image+gain",), fovy=60.0)
        with np.load(tmp_path / f"{spec.key}.npz") as z:
            assert "motion_image+gain" in z.files and "motion_imu" not in z.files
            fovy.append(float(z["camera_fovy"]))
    assert all(40 <= f <= 90 for f in fovy) and fovy[0] != fovy[1]
    clips.record_clip(spec, str(tmp_path), "small")  # the walker's: the world's camera
    with np.load(tmp_path / f"{spec.key}.npz") as z:
        assert float(z["camera_fovy"]) == 55.0 and "motion_imu" in z.files


def test_the_video_tasks_detectors_take_its_front_end_and_no_other():
    assert CalibrateConfig(task="video", detectors=("lgmd1", "feedback-open-loop")
                           ).detectors == ("lgmd1+image+gain", "feedback-open-loop+image+gain")
    assert all(d.endswith("+image+gain") for d in CalibrateConfig(task="video").detectors)
    with pytest.raises(ValueError, match="the video task's front ends are \\+image\\+gain"):
        CalibrateConfig(task="video", detectors=("lgmd1+imu",))
    with pytest.raises(ValueError, match="the walker task's front ends are \\+image, \\+imu"):
        CalibrateConfig(detectors=("lgmd1+image+gain",))


def test_the_video_objective_scores_silence_and_alarming_on_everything_zero():
    kinds = np.array(["jitter", "stationary", "near_miss", "non_looming", "non_looming"])
    collision = np.isin(kinds, ("jitter", "stationary"))
    silent, always = ~collision, collision  # a hit is silence on the other kinds
    balanced = np.array([True, False, True, True, False])  # alarms 0.5, silences 0.75

    def value(objective, hit):
        score, _ = objective.value(kinds, obj.pack_hits(np.tile(hit[:, None], 3)),
                                   slice(0, 1))
        return float(score[0])

    assert value(obj.VIDEO, silent) == 0 and value(obj.VIDEO, always) == 0
    assert value(obj.VIDEO, balanced) == pytest.approx(np.sqrt(0.5 * 0.75))
    assert value(obj.WALKER, silent) > 0  # the plain mean pays silence
    with pytest.raises(ValueError, match="collision kind and of a silence kind"):
        obj.VIDEO.value(kinds[:2], obj.pack_hits(np.ones((2, 3), bool)), slice(0, 1))


def test_the_video_objective_takes_an_alarm_of_four_rising_frames():
    """A shaken clip's one-frame surges and a transient that falls back are no alarm;
    four frames above the threshold, climbing, are, the first alarm being the fourth
    (within the jitter window: the last 15%)."""
    assert obj.VIDEO.alarm == AlarmRule(4, rising=True) and obj.WALKER.alarm == AlarmRule()
    surges = np.full(40, 0.55)
    surges[[5, 6, 9]] = 0.9
    surges[20:26] = [0.95, 0.9, 0.88, 0.86, 0.85, 0.84]  # an onset transient
    held = surges.copy()
    held[35:39] = [0.82, 0.85, 0.9, 0.96]
    labels = [obj.ClipLabel("non_looming", 40, None), obj.ClipLabel("jitter", 40, 39)]
    thresholds = np.array([0.8])
    assert obj.hits(labels, [surges, held], thresholds, obj.VIDEO.alarm)[:, 0].tolist() == [
        True, True]
    assert obj.hits(labels, [surges, held], thresholds)[:, 0].tolist() == [False, False]
    assert obj.VIDEO.identity()["alarm"] == {"frames": 4, "rising": True}


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


def test_the_footage_check_counts_and_judges_as_the_outside_check():
    """docs/experiments/tools/footage_check.py: fired counts per kind (a crash only at or before its
    collision), the mean SI of the shaken crashes (a silent clip 1.0), and the targets
    missed."""
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(TOOLS))
        check = importlib.import_module("footage_check")

    def row(kind, first, si=1.0, collision=None):
        return {"set": "--preset video", "detector": "m/video", "kind": kind,
                "first_alarm": first, "si": si, "collision_frame": collision, "frames": 50}

    rows = [row("approaching", 40), row("approaching", 45),
            *[row("non_approach", None)] * 3, row("non_approach", 3),
            *[row("crash", 48, collision=49)] * 7, row("crash", None, collision=49),
            *[row("shaken_crash", 45, 0.92)] * 4, row("shaken_crash", None)]
    assert check.verdict(rows) == []
    line = check.table(rows).splitlines()[2]
    assert line == ("| --preset video | m/video | 2/2 | 1/4 | 7/8 | 0.94 (4/5) | none |")
    worse = [*rows[:2], *[row("non_approach", 3)] * 2, *rows[4:6],
             *[row("crash", None, collision=49)] * 2, *rows[8:],
             *[row("shaken_crash", 2, 0.04)] * 3]
    assert check.verdict(worse) == ["non-approach", "crashes", "SI"]
