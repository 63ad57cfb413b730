"""The video calibration task (`lgmd-sim calibrate --task video`): the walker's clips and
synthetic stimuli that do not loom, with a real camera's noise; every detector with the
front end a video allows; presets named `video` that score, run on their own, what the
calibration scored."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim.calibration import clips
from lgmd_sim.calibration import objective as obj
from lgmd_sim.calibration.run import CalibrateConfig
from lgmd_sim.calibration.tasks import TASKS
from lgmd_sim.signals.metrics import AlarmRule

ROOT = Path(__file__).resolve().parents[2]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


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
