"""`lgmd-sim benchmark` on a tiny protocol 2: every track with each level apart, the
published episodes `lgmd-sim verify` replays, the leaderboard's J50 and figure, and a
row claiming what its parts do not hold refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from lgmd_sim import cli

from protocols import tiny_protocol

ROOT = Path(__file__).resolve().parents[2]


V2_ROW = ROOT / "docs/benchmark/v2/runs/lgmd1-robot-image/result.json"


def _edit_levels(r: dict) -> None:
    r["parts"]["goal"]["levels"] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def _edit_frames(r: dict) -> None:
    r["parts"]["detection"]["sums"][0][4] = r["parts"]["detection"]["sums"][0][5] + 1


def _edit_detection(r: dict) -> None:
    r["scores"]["detection"] += 0.1


@pytest.fixture(scope="module")
def tiny_v2(tmp_path_factory):
    """lgmd1/robot-image and Straight through a tiny protocol 2."""
    tmp = tmp_path_factory.mktemp("v2")
    tiny = tiny_protocol(tmp, "v2")
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
