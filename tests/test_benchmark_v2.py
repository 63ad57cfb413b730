"""Protocol 2: its file checked, the camera track's score and the dose-response (J50) on
hand-made parts, and end to end on a tiny protocol 2: every track, the published
episodes that `lgmd-sim verify` replays against, the leaderboard's J50 column and
figure, and results of the two versions never merged."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import cli
from lgmd_sim.benchmark import camera, protocol, scores
from lgmd_sim.benchmark.leaderboard import against_driving, spearman

SHIPPED = protocol.PROTOCOLS["v2"].read_text()
ROOT = Path(__file__).resolve().parents[1]


def _tiny(tmp_path: Path, **changes: str) -> Path:
    """v2 at 64 x 64 at jitter 0 and 2, two episodes a track, one clip a scenario or
    stimulus and level; `changes` replace whole lines ("key = value") of it, the first of
    that key."""
    text = SHIPPED.replace('resolution = "rl"', 'resolution = "small"')
    text = text.replace("jitter = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0]", "jitter = [0.0, 2.0]")
    text = text.replace("jitter = [0.0, 1.0]", "jitter = [1.0]")
    text = text.replace("episodes = 20", "episodes = 2").replace("clips = 20", "clips = 1")
    text = text.replace("clips = 6", "clips = 1")
    text = re.sub(r"reference_distance_m = \[.*\]", "reference_distance_m = [3.0, 3.0]", text)
    text = text.replace("bootstrap = 2000", "bootstrap = 200")
    for old, new in changes.items():
        text = re.sub(rf"(?m)^{re.escape(old)} = .*$", new, text, count=1)
    file = tmp_path / "tiny2.toml"
    file.write_text(text)
    return file


@pytest.mark.parametrize(("change", "message"), [
    ({"approaching": 'approaching = ["HandheldApproach"]'},
     "detection.approaching: scenario 'HandheldApproach' does not carry the camera on the robot"),
    ({"clear": 'clear = ["RobotApproach"]'},
     "detection.clear: scenario 'RobotApproach' is in detection.approaching already"),
    ({"window_s": "window_s = [1.2, 0.6]"}, "detection.window_s must be [low, high]"),
    ({"cruise": "cruise = 0.6\nnothing = 1"}, "unknown key nothing"),
    ({"version": "version = 3"}, "a protocol is of version 1 or 2"),
    ({"jitter": "jitter = [1.0, 2.0]"}, "goal.jitter must rise from 0"),
])
def test_a_bad_protocol_2_is_one_line_naming_the_key(tmp_path, change, message):
    file = _tiny(tmp_path, **change)
    with pytest.raises(ValueError) as exc:
        protocol.load(file)
    text = str(exc.value)
    assert len(text.splitlines()) == 1 and str(file) in text and message in text, text


def test_the_arena_runs_the_goal_s_levels_and_the_camera_only_forward_speeds(tmp_path):
    text = _tiny(tmp_path).read_text()
    arena = text.replace("[arena]\nscenario = \"ArenaRoam\"\njitter = [0.0, 2.0]",
                         "[arena]\nscenario = \"ArenaRoam\"\njitter = [0.0, 1.0]")
    (tmp_path / "a.toml").write_text(arena)
    with pytest.raises(ValueError, match=r"arena\.jitter must be goal\.jitter"):
        protocol.load(tmp_path / "a.toml")
    (tmp_path / "b.toml").write_text(text.replace("cruise = [0.45, 0.6, 0.75]",
                                                  "cruise = [0.45, 1.5]"))
    with pytest.raises(ValueError, match=r"detection.cruise: 1.5 is not a forward action"):
        protocol.load(tmp_path / "b.toml")
    no_stimuli = re.sub(r"(?s)\[stimuli\].*?(?=\[calibration\])", "", text)
    (tmp_path / "c.toml").write_text(no_stimuli)
    with pytest.raises(ValueError, match="no key stimuli"):
        protocol.load(tmp_path / "c.toml")


def test_clips_drive_at_each_speed_in_turn():
    track = protocol.load("v2").detection
    assert [track.cruise_of(s) for s in track.seeds] == [0.45, 0.6, 0.75] * 2
    assert len(camera.clips(track)) == 4 * 6 * 6


# --- scores -------------------------------------------------------------------------------


def _clip(kind: str, outcome: str, seed: int = 0, jitter: float = 0.0, **frames: int) -> dict:
    counts = {"window_frames": 10, "window_alarmed": 0, "clear_frames": 100,
              "clear_silent": 100, **frames}
    return {"kind": kind, "outcome": outcome, "seed": seed, "jitter": jitter, **counts}


def test_the_camera_score_is_the_mean_of_four_rates_each_level_alike():
    records = [_clip("approach", "hit", window_alarmed=5, clear_silent=90),
               _clip("approach", "early"),
               _clip("clear", "silent", window_frames=0),
               _clip("clear", "false_alarm", window_frames=0, clear_silent=50),
               # jitter 2: all wrong but the clear frames
               _clip("approach", "miss", jitter=2.0), _clip("clear", "false_alarm", jitter=2.0,
                                                             window_frames=0)]
    parts = camera.parts(records, (0.0, 2.0))
    level0 = np.mean([1 / 2, 1 / 2, 5 / 20, (90 + 100 + 100 + 50) / 400])
    level2 = np.mean([0, 0, 0 / 10, 200 / 200])
    assert parts.level_scores() == pytest.approx([level0, level2])
    assert parts.score() == pytest.approx((level0 + level2) / 2)


def test_a_rate_with_nothing_to_count_is_left_out_not_nan():
    # no window frame at all: the window rate is left out of the level's mean
    records = [_clip("approach", "miss", window_frames=0), _clip("clear", "silent",
                                                                 window_frames=0)]
    parts = camera.parts(records, (0.0,))
    assert parts.score() == pytest.approx(np.mean([0, 1, 1]))


def test_j50_is_where_the_score_halves_linear_between_levels():
    levels = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0]
    assert scores.j50(np.array([0.8, 0.7, 0.5, 0.4, 0.3, 0.1]), levels) == 1.5
    assert scores.j50(np.array([0.8, 0.2, 0, 0, 0, 0]), levels) == pytest.approx(1 / 3)
    assert scores.j50(np.array([0.8, 0.7, 0.6, 0.5, 0.5, 0.45]), levels) == np.inf
    assert np.isnan(scores.j50(np.array([0.0, 0.1, 0, 0, 0, 0]), levels))
    # a rise before the fall does not move it: the first level at or below half
    assert scores.j50(np.array([0.4, 0.9, 0.3, 0.1, 0.1, 0.0]), levels) == pytest.approx(1.25)


def test_the_dose_response_interval_holds_its_j50_and_is_the_same_twice():
    rng = np.random.default_rng(0)
    levels = (0.0, 1.0, 2.0, 3.0)
    falling = np.clip(np.array([0.8, 0.6, 0.3, 0.1]) + rng.normal(0, 0.1, (20, 4)), 0, 1)
    sums = np.stack([falling, np.ones_like(falling)], axis=-1).reshape(20, -1)
    part = scores.Parts(tuple(range(20)), sums, levels)
    dose = scores.dose_response({"goal": part, "arena": part}, 500, 0)
    low, high = dose["j50_interval"]
    assert low <= dose["j50"] <= high and 1.0 < dose["j50"] < 2.5
    assert dose == scores.dose_response({"goal": part, "arena": part}, 500, 0)
    assert scores.dose_response({"goal": scores.Parts((0,), np.ones((1, 2)))}, 10, 0) is None


def test_spearman_ranks_ties_by_their_mean():
    assert spearman([1, 2, 3, 4], [10, 20, 30, 40]) == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    assert spearman([1, 1, 2, 3], [1, 2, 3, 4]) == pytest.approx(
        np.corrcoef([1.5, 1.5, 3, 4], [1, 2, 3, 4])[0, 1])


def test_spearman_is_computed_over_the_detector_rows_only():
    rows = [{"scores": {"detection": d, "overall": o}} for d, o in
            ((0.1, 0.1), (0.2, 0.3), (0.3, 0.2), (0.4, 0.4))]
    rows.append({"scores": {"overall": 0.9}})  # a controller: no detection score
    rho, n = against_driving(rows, "detection")
    assert n == 4 and rho == pytest.approx(0.8)
    assert against_driving(rows[:2], "detection") is None  # too few to rank


# --- end to end ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tiny_v2(tmp_path_factory):
    """lgmd1/robot-image and Straight through a tiny protocol 2."""
    tmp = tmp_path_factory.mktemp("v2")
    tiny = _tiny(tmp)
    out = tmp / "out"
    assert cli.main(["benchmark", "lgmd1/robot-image", "straight", "--protocol", str(tiny),
                     "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    return tiny, out


@pytest.mark.slow  # a tiny protocol 2, two entries: about 40 s
def test_a_v2_row_holds_every_track_each_level_apart_and_its_episodes(tiny_v2):
    _, out = tiny_v2
    result = json.loads((out / "lgmd1-robot-image" / "result.json").read_text())
    assert result["protocol"]["version"] == 2
    assert set(result["scores"]) == {"goal", "arena", "detection", "stimuli", "overall"}
    for track in ("goal", "arena", "detection"):
        assert result["parts"][track]["levels"] == [0.0, 2.0]
    assert "levels" not in result["parts"]["stimuli"]
    detection = result["metrics"]["detection"]
    assert set(detection["outcomes"]) == {"RobotApproach", "RobotWallAhead",
                                          "RobotOpenGround", "RobotPassBy"}
    episodes = json.loads((out / "lgmd1-robot-image" / "episodes.json").read_text())
    assert [len(episodes[t]) for t in ("goal", "arena")] == [4, 4]
    assert all("fingerprint" in r and "top_view" not in r for r in episodes["goal"])


@pytest.mark.slow
def test_the_v2_leaderboard_gives_j50_and_its_figure_and_never_merges_v1(tiny_v2, tmp_path,
                                                                         capsys):
    tiny, out = tiny_v2
    md = tmp_path / "board.md"
    assert cli.main(["leaderboard", str(out / "lgmd1-robot-image"), str(out / "straight"),
                     "--protocol", str(tiny), "--out", str(md)]) == 0
    table = md.read_text()
    assert "| J50 |" in table and "Synthetic stimuli" in table
    assert (tmp_path / "board-jitter.png").stat().st_size > 0
    v1_row = ROOT / "docs/benchmark/runs/straight"
    assert cli.main(["leaderboard", str(out / "straight"), str(v1_row), "--protocol",
                     str(tiny), "--out", str(tmp_path / "mixed.md")]) == 2
    err = capsys.readouterr().err.strip()
    assert "a result of another protocol (version 1" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "mixed.md").exists()


@pytest.mark.slow  # replays a published row's 8 episodes: about 20 s
def test_verify_replays_a_published_row_from_its_episodes_json(tiny_v2, tmp_path, capsys):
    tiny, out = tiny_v2
    row = tmp_path / "straight"
    shutil.copytree(out / "straight", row)
    for track in ("goal", "arena"):  # as published: the run folders stay where it ran
        shutil.rmtree(row / track)
    args = ["verify", str(row), "--protocol", str(tiny), "--all", "--workers", "1",
            "--no-progress"]
    assert cli.main(args) == 0
    assert "8 of 8 episodes identical" in capsys.readouterr().out
    episodes = json.loads((row / "episodes.json").read_text())
    episodes["arena"][1]["min_clearance_m"] += 1.0
    (row / "episodes.json").write_text(json.dumps(episodes))
    assert cli.main(args) == 1
    assert "but its record's min_clearance_m" in capsys.readouterr().out
    del episodes["goal"][0]
    (row / "episodes.json").write_text(json.dumps(episodes))
    assert cli.main(args) == 2
    assert "3 goal episodes, its run holds 4" in capsys.readouterr().err


# --- the audit of a v2 row ----------------------------------------------------------------

V2_ROW = ROOT / "docs/benchmark/v2/runs/lgmd1-robot-image/result.json"


def _edit_levels(r: dict) -> None:
    r["parts"]["goal"]["levels"] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def _edit_frames(r: dict) -> None:
    r["parts"]["detection"]["sums"][0][4] = r["parts"]["detection"]["sums"][0][5] + 1


def _edit_detection(r: dict) -> None:
    r["scores"]["detection"] += 0.1


@pytest.mark.parametrize(("edit", "field"), [
    (_edit_levels, "parts.goal.levels are not the protocol's goal jitter levels"),
    (_edit_frames, "parts.detection.sums[0]"),
    (_edit_detection, "scores.detection"),
])
def test_a_v2_row_claiming_what_its_parts_do_not_hold_is_refused(tmp_path, capsys, edit,
                                                                 field):
    result = json.loads(V2_ROW.read_text())
    edit(result)
    file = tmp_path / "row" / "result.json"
    file.parent.mkdir()
    file.write_text(json.dumps(result))
    assert cli.main(["leaderboard", str(file), "--out", str(tmp_path / "b.md")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and field in err and "not ranked" in err, err


def test_the_shipped_v2_rows_pass_the_audit(tmp_path):
    from lgmd_sim.benchmark.leaderboard import load_result

    rows = sorted((ROOT / "docs/benchmark/v2/runs").glob("*/result.json"))
    assert len(rows) >= 19
    for row in rows:
        load_result(row, protocol.load("v2"))
