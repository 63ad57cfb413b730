"""`lgmd-sim calibrate --task robot`: the robot objective on hand-made traces, the robot's
preset names beside the walker's, and a tiny robot calibration end to end."""

from __future__ import annotations

import dataclasses
import json
import math
import shutil

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.calibration import clips, report, robot, run, tasks
from lgmd_sim.calibration.objective import THRESHOLDS
from lgmd_sim.controllers import options
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.models import presets

#: Frames 0..100 of a straight approach: time to collision (100 - t) / 30 s, so that the
#: window [0.5, 1.5] s is frames 55..85 and the clear frames (beyond 2 s) are 0..39.
T = np.arange(101)
TTC = (100 - T) / 30.0
#: Frames 60..64: the threat is behind (beyond 90 degrees): not window frames.
BEARING = np.where((T >= 60) & (T <= 64), 2.0, 0.0)
#: The potential ramps up by 0.004 a frame: it first exceeds a threshold th at frame
#: floor((th - 0.5) / 0.004) + 1.
RAMP = 0.5 + 0.004 * T


@pytest.fixture
def placeholder_window(monkeypatch):
    """The window the hand-made traces are made for, whatever the measured one is."""
    monkeypatch.setattr(robot, "TTC_LO", 0.5)
    monkeypatch.setattr(robot, "TTC_HI", 1.5)


def _approach() -> robot.FrameLabel:
    return robot.frame_label("approach", TTC, BEARING)


def _clear() -> robot.FrameLabel:
    return robot.frame_label("clear", np.full(101, math.inf), np.zeros(101))


@pytest.mark.usefixtures("placeholder_window")
def test_window_frames_are_ahead_within_the_ttc_window_and_clear_ones_beyond_the_horizon():
    label = _approach()
    assert robot.HORIZON == 2.0 and robot.AHEAD == 90.0  # the benchmark's and the Oracle's
    assert T[label.window].tolist() == [*range(55, 60), *range(65, 86)]
    assert T[label.clear].tolist() == list(range(40))
    assert not (label.window & label.clear).any()
    assert _clear().clear.all() and not _clear().window.any()


def test_a_threat_passing_beside_a_clear_clip_makes_no_window_frames():
    # an obstacle beside the path closes in (its TTC in the window) and is passed: the
    # per-clip part wants silence there, and so does the per-frame part
    passing = robot.frame_label("clear", np.full(10, 1.0), np.zeros(10))
    assert not passing.window.any() and not passing.clear.any()


@pytest.mark.usefixtures("placeholder_window")
def test_an_approach_is_a_hit_only_when_its_first_alarm_falls_in_the_window():
    at = np.array([0.602, 0.73, 0.745, 0.85, 0.95])  # first alarm: 26, 58, 62, 88, never
    hit = robot.hits([_approach()], [RAMP], at)
    assert hit.tolist() == [[False, True, False, False, False]]  # too early, hit, behind,
    # too late, never


def test_a_clear_clip_is_a_hit_only_when_it_never_alarms():
    assert robot.hits([_clear()], [RAMP], np.array([0.85, 0.95])).tolist() == [[False, True]]


@pytest.mark.usefixtures("placeholder_window")
def test_frame_balanced_accuracy_by_hand():
    at = np.array([0.602, 0.73, 0.95])
    alarmed, silent = robot.frame_counts([_approach(), _clear()], [RAMP, RAMP], at)
    # window frames (26): those past the first crossing; clear frames (40 + 101): those
    # up to it, in the approach (frames 0..39) and in the clear clip (frames 0..100)
    assert alarmed.tolist() == [26, 23, 0]
    assert silent.tolist() == [26 + 26, 40 + 58, 40 + 101]


@pytest.mark.usefixtures("placeholder_window")
def test_the_objective_is_the_mean_of_its_three_parts_from_one_run():
    labels = [_approach(), _clear()]
    potentials = [RAMP, np.full(101, 0.5)]  # the clear clip never alarms
    scores = json.loads(json.dumps(robot.ROBOT.scores(labels, potentials, THRESHOLDS)))
    i = int(np.flatnonzero(np.isclose(THRESHOLDS, 0.73))[0])
    score, parts = robot.ROBOT.value(np.array(["approach", "clear"]), scores, slice(i, i + 1))
    frames = (23 / 26 + (40 + 101) / 141) / 2
    assert {k: float(v[0]) for k, v in parts.items()} == pytest.approx(
        {"approach": 1.0, "clear": 1.0, "frames": frames})
    assert score.tolist() == pytest.approx([(2 + frames) / 3])
    full, _ = robot.ROBOT.value(np.array(["approach", "clear"]), scores, slice(None))
    assert full.shape == THRESHOLDS.shape and full[i] == pytest.approx(score[0])


@pytest.mark.usefixtures("placeholder_window")
def test_robot_frames_judges_the_same_clips_by_the_video_presets_alarm_rule():
    """A one-frame surge in the window alarms by the paper's rule and not by 4 rising
    frames; a climb through the window alarms by both."""
    surge, climb = np.full(101, 0.5), np.where(T >= 66, 0.9, 0.5) + 0.001 * T
    surge[70] = 0.9
    i = int(np.flatnonzero(np.isclose(THRESHOLDS, 0.8))[0])
    labels, potentials = [_approach(), _approach(), _clear()], [surge, climb, surge]
    for objective, hit in ((robot.ROBOT, [True, True, False]),
                           (robot.ROBOT_FRAMES, [False, True, True])):
        scores = json.loads(json.dumps(objective.scores(labels, potentials, THRESHOLDS)))
        hits = robot.unpack_hits(scores["hits"], 3)[:, i]
        assert hits.tolist() == hit, objective.alarm
    assert robot.ROBOT_FRAMES.identity() == {**robot.ROBOT.identity(),
                                             "alarm": {"frames": 4, "rising": True}}
    assert tasks.preset_name("lgmd1+image", "robot-frames") == ("lgmd1", "robot-frames-image")
    assert tasks.TASKS["robot-frames"].preset_params(None, "rl") == {
        "alarm_frames": 4, "alarm_rising": True}  # its presets alarm as they were chosen


def test_the_robot_presets_are_named_apart_from_the_walker_ones():
    assert tasks.preset_name("lgmd1", "robot") == ("lgmd1", "robot")
    assert tasks.preset_name("lgmd1+imu", "robot") == ("lgmd1", "robot-imu")
    assert tasks.preset_name("f_on+image", "robot") == ("f_on", "robot-image")
    assert tasks.preset_name("feedback-open-loop", "robot") == ("feedback", "robot-open-loop")
    assert tasks.preset_name("feedback-open-loop+image", "robot") == (
        "feedback", "robot-open-loop-image")
    assert tasks.preset_name("lgmd1+image") == ("lgmd1", "calibrated-image")  # the walker's


def _calibration(task: str, names: list[str], **params) -> dict:
    score = {"objective": 1.0}
    return {"command": f"lgmd-sim calibrate --task {task}", "objective": task,
            "search_seeds": [0, 1], "heldout_seeds": [100, 1], "resolution": "small",
            "budget": 1, "figure": "calibration.png",
            "presets": {"lgmd1": {n: {"from": "published", "params": dict(params),
                                      "search": score, "heldout": score} for n in names}}}


def test_robot_presets_merge_beside_the_walker_ones(tmp_path, monkeypatch):
    monkeypatch.setenv("LGMD_SIM_DATA_DIR", str(tmp_path / "user"))
    shipped = tmp_path / "shipped.json"
    shutil.copyfile(presets.CALIBRATED, shipped)
    monkeypatch.setattr(presets, "CALIBRATED", shipped)
    target = presets.user_presets_file()
    presets.merge_presets(target, _calibration("walker", ["calibrated"], c_sig=2.0))
    presets.merge_presets(target, _calibration(
        "robot", ["robot", "robot-imu", "robot-image"], c_sig=5.0, threshold=0.8))
    saved = json.loads(target.read_text())["presets"]["lgmd1"]
    assert list(saved) == ["calibrated", "robot", "robot-imu", "robot-image"]
    assert saved["calibrated"]["calibration"]["command"].endswith("walker")
    assert saved["robot-imu"]["calibration"]["command"].endswith("robot")
    assert models.make("lgmd1", preset="calibrated").params.c_sig == 2.0
    assert models.make("lgmd1", preset="robot").params.threshold == 0.8
    assert options.detectors("lgmd1", "robot,robot-imu,robot-image") == (
        ("lgmd1", "robot"), ("lgmd1", "robot-imu"), ("lgmd1", "robot-image"))


#: Every detector, in `search.detector_list()`'s order: both tasks' default.
DETECTORS = ["feedback", "feedback-open-loop", "lgmd1", "lgmd2", "f_on", "f_off",
             *(f"{d}+{front}" for d in ("feedback", "feedback-open-loop", "lgmd1", "lgmd2",
                                        "f_on", "f_off") for front in ("image", "imu"))]


#: What every calibration run records of its clips beyond its groups: plain looks, the
#: world's field of view, the paper's alarm rule.
PLAIN = {"alarm": {"frames": 1, "rising": False},
         "looks": {"": {"noise": "", "scene": {}, "background": "texture"}}, "fovy": None}


def test_a_walker_run_is_identified_by_every_key_of_its_configuration():
    assert json.loads(json.dumps(run.CalibrateConfig().as_json())) == {
        "calibration": 1, "task": "walker", "cruise": None, "detectors": DETECTORS,
        "budget": 32, "search_seeds": [0, 8], "heldout_seeds": [100, 8], "resolution": "rl",
        "groups": {"jitter": [["HandheldApproach", [1.0, 1.5]],
                              ["MutualApproach", [1.0, 1.5]]],
                   "stationary": [["StationaryApproach", [0.0]], ["HandheldApproach", [0.0]],
                                  ["MutualApproach", [0.0]]],
                   "near_miss": [["PassBy", [0.0, 1.0]]]},
        "late": 0.15, **PLAIN, "seed": 0}


def test_a_robot_run_is_identified_by_its_clips_cruise_and_window():
    jitters = [0.0, 1.0, 2.0]
    assert json.loads(json.dumps(run.CalibrateConfig(task="robot").as_json())) == {
        "calibration": 1, "task": "robot", "cruise": 0.6, "detectors": DETECTORS,
        "budget": 32, "search_seeds": [0, 8], "heldout_seeds": [100, 8], "resolution": "rl",
        "groups": {"approach": [["RobotApproach", jitters], ["RobotWallAhead", jitters]],
                   "clear": [["RobotOpenGround", jitters], ["RobotPassBy", jitters]]},
        "window": [0.6, 1.15], "horizon": 2.0, "ahead": 90.0, **PLAIN, "seed": 0}


def test_the_window_is_the_one_the_oracle_measured():
    # docs/experiments/tools/oracle_window.py: the horizons at which the Oracle meets the
    # closed-loop target
    assert (robot.TTC_LO, robot.TTC_HI) == (0.6, 1.15)


@pytest.mark.usefixtures("placeholder_window")
def test_a_part_the_set_lacks_is_left_out_of_the_objective_and_a_dash_in_the_summary():
    # approach clips only: no clear part; the frames part has the approach's clear frames
    scores = robot.ROBOT.scores([_approach()], [RAMP], THRESHOLDS)
    record = {"detector": "lgmd1", "index": 0, "params": {},
              "sets": {"search": scores, "heldout": scores}}
    kinds = {"search": [{"kind": "approach"}], "heldout": [{"kind": "approach"}]}
    chosen = run.choose([record], kinds, robot.ROBOT)
    assert set(chosen["search"]) == {"objective", "approach", "frames"}
    assert chosen["search"]["objective"] == pytest.approx(
        (chosen["search"]["approach"] + chosen["search"]["frames"]) / 2)
    row = report.summary_markdown([chosen], robot.ROBOT).splitlines()[2]
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[0] == "lgmd1" and cells[4] == "-"  # approach, clear, frames: columns 3-5
    assert cells[3] == "{0:.2f} / {0:.2f}".format(chosen["search"]["approach"])
    report.calibration_figure([chosen], robot.ROBOT).canvas.draw()  # the clear panel empty


@pytest.mark.slow
def test_a_tiny_robot_calibration_end_to_end(tmp_path, monkeypatch):
    # one approach and one clear scenario at one jitter level keep it quick
    small = {"approach": [("RobotApproach", (1.0,))], "clear": [("RobotOpenGround", (1.0,))]}
    monkeypatch.setitem(tasks.TASKS, "robot", dataclasses.replace(tasks.TASKS["robot"],
                                                                groups=small))
    out = tmp_path / "cal"
    result = run.calibrate(run.CalibrateConfig(
        task="robot", detectors=("lgmd1", "lgmd1+imu"), budget=2, seeds=1,
        resolution="small"), out, RunOptions(workers=1, progress=False))
    data = json.loads((out / "calibrated.json").read_text())
    assert set(data["presets"]["lgmd1"]) == {"robot", "robot-imu"}
    entry = data["presets"]["lgmd1"]["robot-imu"]
    assert entry["params"]["stabilize"] == "imu"
    assert set(entry["heldout"]) == {"objective", "approach", "clear", "frames"}
    assert data["objective"] == robot.__doc__.strip()
    summary = (out / "summary.md").read_text()
    assert "approach clips hit" in summary and "frame balanced accuracy" in summary
    assert (out / "calibration.png").stat().st_size > 10_000
    # the robot drives at the closed-loop benchmark's cruise: about 0.6 m/s towards 4 m
    record = json.loads((out / "records" / "clip-RobotApproach-j1-s0.json").read_text())
    assert 150 < record["collision_frame"] < 250
    # the chosen threshold scores on the held-out clips what the objective says there
    heldout = [json.loads(p.read_text()) for p in sorted((out / "records").glob("clip-*-s100*"))]
    labels = [robot.ROBOT.label(r, clips.load_truth(out / "clips", r["key"], robot.TRUTH))
              for r in heldout]
    model = models.make("lgmd1", preset="published", **result.rows[0]["params"])
    potentials = []
    for r in heldout:
        frames, _ = clips.load_clip(out / "clips", r["key"])
        model.reset()
        potentials.append(np.array([model.step(f).potential for f in frames]))
    i = int(np.flatnonzero(np.isclose(THRESHOLDS, result.rows[0]["threshold"]))[0])
    scores = robot.ROBOT.scores(labels, potentials, THRESHOLDS)
    score, _ = robot.ROBOT.value(np.array([r["kind"] for r in heldout]), scores,
                                 slice(i, i + 1))
    assert score[0] == pytest.approx(result.rows[0]["heldout"]["objective"])


@pytest.mark.parametrize("names", [["lgmd1"], ["feedback", "feedback-open-loop+imu", "lgmd1",
                                               "lgmd1+image", "f_on+imu"]])
def test_calibration_png_names_the_robot_parts_and_lays_out(names):
    score = {"objective": 0.6, "approach": 0.5, "clear": 1.0, "frames": 0.3}
    fig = report.calibration_figure([{"detector": n, "search": score, "heldout": score}
                                  for n in names], robot.ROBOT)
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    assert [ax.get_title() for ax in fig.axes] == list(robot.ROBOT.titles.values())
    titles = [ax.title.get_window_extent(renderer) for ax in fig.axes]
    for box in [*titles, fig.legends[0].get_window_extent(renderer)]:  # nothing clipped
        assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1 and box.y1 <= fig.bbox.y1
    for i, a in enumerate(titles):
        assert not any(a.overlaps(b) for b in titles[i + 1:])
