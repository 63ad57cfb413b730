"""Protocol 2: its file checked, the camera track's score and the dose-response (J50) on
hand-made parts, and end to end on a tiny protocol 2: every track, the published
episodes that `lgmd-sim verify` replays against, the leaderboard's J50 column and
figure, and results of the two versions never merged."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim.benchmark import camera, protocol, scores
from lgmd_sim.benchmark.leaderboard import against_driving, spearman

from protocols import tiny_protocol

SHIPPED = protocol.PROTOCOLS["v2"].read_text()
ROOT = Path(__file__).resolve().parents[2]


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
    file = tiny_protocol(tmp_path, "v2", **change)
    with pytest.raises(ValueError) as exc:
        protocol.load(file)
    text = str(exc.value)
    assert len(text.splitlines()) == 1 and str(file) in text and message in text, text


def test_the_arena_runs_the_goal_s_levels_and_the_camera_only_forward_speeds(tmp_path):
    text = tiny_protocol(tmp_path, "v2").read_text()
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


# --- the audit of a v2 row ----------------------------------------------------------------









def test_the_shipped_v2_rows_pass_the_audit(tmp_path):
    from lgmd_sim.benchmark.leaderboard import load_result

    rows = sorted((ROOT / "docs/benchmark/v2/runs").glob("*/result.json"))
    assert len(rows) >= 19
    for row in rows:
        load_result(row, protocol.load("v2"))
