"""`lgmd-sim benchmark` end to end on a tiny protocol: a row's result, resuming, the
leaderboard of rows, --calibrate, entries refused before any runs, one run per folder, a
Ray address where nothing answers, the smoke mode and its result refused by the board."""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import pytest

from lgmd_sim import cli
from lgmd_sim.benchmark import protocol
from lgmd_sim.benchmark.leaderboard import leaderboard

from protocols import tiny_protocol

ROOT = Path(__file__).resolve().parents[2]


def _timeless(file: Path) -> dict:
    """A result but its wall time and command line (its folder's name in it)."""
    result = json.loads(file.read_text())
    del result["timing"], result["command"]
    return result


def _shipped_policy_in(folder: Path) -> Path:
    from lgmd_sim import policies

    shutil.copytree(policies.path(policies.DEFAULT), folder)
    return folder


def _benchmark(tiny: Path, out: Path, *entry: str) -> int:
    return cli.main(["benchmark", *entry, "--protocol", str(tiny), "--out", str(out),
                     "--workers", "1", "--no-progress"])


@pytest.mark.slow  # whole benchmarks of a tiny protocol: 15-50 s each
def test_the_same_command_gives_the_same_result_and_resumes(tiny_run, tmp_path):
    tiny, out = tiny_run
    again = tmp_path / "again"
    shutil.copytree(out / "straight", again / "straight")
    records = sorted((again / "straight" / "goal" / "records").iterdir())
    records[0].unlink()  # as if killed before its episode finished
    (again / "straight" / "result.json").unlink()
    assert _benchmark(tiny, again, "straight") == 0
    assert _timeless(again / "straight" / "result.json") == _timeless(
        out / "straight" / "result.json")


@pytest.mark.slow  # whole benchmarks of a tiny protocol: 15-50 s each
def test_the_leaderboard_ranks_the_entries_and_refuses_another_protocol(tiny_run, tmp_path,
                                                                         capsys):
    tiny, out = tiny_run
    md = tmp_path / "board.md"
    assert cli.main(["leaderboard", str(out / "lgmd1-published"), str(out / "straight"),
                     "--protocol", str(tiny), "--out", str(md)]) == 0
    table = md.read_text()
    assert "`lgmd1/published`" in table and "`straight`" in table
    assert (tmp_path / "board.png").stat().st_size > 0
    other = tiny_protocol(tmp_path, bootstrap="bootstrap = 300")
    assert cli.main(["leaderboard", str(out / "straight"), "--protocol", str(other),
                     "--out", str(tmp_path / "x.md")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "a leaderboard merges one protocol's results" in err
    assert not (tmp_path / "x.md").exists()
    with pytest.raises(ValueError, match="two results of entry 'straight'"):
        leaderboard([out / "straight", out / "straight"], tmp_path / "y.md",
                    protocol.load(tiny))


@pytest.mark.slow  # whole benchmarks of a tiny protocol: 15-50 s each
def test_a_plug_in_calibrated_first_runs_at_the_preset_it_made(tmp_path, monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "plugins"))
    mine = tmp_path / "mine"  # the user's own presets folder, which must stay as it is
    monkeypatch.setenv("LGMD_SIM_DATA_DIR", str(mine))
    tiny = tiny_protocol(tmp_path, budget="budget = 2", seeds="seeds = 1")
    out = tmp_path / "out"
    assert cli.main(["benchmark", "lgmd_plug:Blink+image", "--calibrate", "--protocol",
                     str(tiny), "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    folder = out / "lgmd_plug_Blink-robot-image"
    result = json.loads((folder / "result.json").read_text())
    assert result["entry"]["preset"] == "robot-image"
    tuned = json.loads((folder / "presets" / "calibrated.json").read_text())
    made = tuned["presets"]["lgmd_plug:Blink"]["robot-image"]["params"]
    assert made and made.items() <= result["entry"]["params"].items()
    assert (folder / "calibration" / "run.json").is_file()
    assert not mine.exists()
    assert os.environ["LGMD_SIM_DATA_DIR"] == str(mine)  # as before the command
    # its episodes replay at that preset on worker processes, which the jobs tell it
    assert cli.main(["verify", str(folder), "--protocol", str(tiny), "--all", "--workers",
                     "2", "--no-progress"]) == 0
    assert "4 of 4 episodes identical" in capsys.readouterr().out


@pytest.mark.parametrize("case", ["two policies of one folder name",
                                  "a policy trained at another frame size"])
def test_entries_that_cannot_all_run_are_refused_before_any_runs(tmp_path, capsys, case):
    if case == "two policies of one folder name":
        tiny = tiny_protocol(tmp_path, resolution='resolution = "rl"')
        given = [str(_shipped_policy_in(tmp_path / d / "pol")) for d in ("a", "b")]
        expected = "one folder"
    else:  # the tiny protocol renders 64 x 64, the policy was trained on 120 x 160
        tiny = tiny_protocol(tmp_path)
        given = [str(_shipped_policy_in(tmp_path / "pol"))]
        expected = "trained on 120x160 frames, the protocol runs 64x64"
    out = tmp_path / "out"
    assert _benchmark(tiny, out, "straight", *given) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expected in err, err
    assert not out.exists()  # `straight`, first, did not run


def test_a_second_benchmark_of_the_same_entry_into_the_same_folder_is_refused(tmp_path, capsys):
    """Two at once both computed everything, and run.json lost one's wall time."""
    from lgmd_sim.core.fileio import held_lock

    out = tmp_path / "out"
    with held_lock(out / ".straight.lock"):  # a benchmark of straight, running
        assert _benchmark(tiny_protocol(tmp_path), out, "straight") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "another lgmd-sim benchmark is running" in err, err
    assert sorted(p.name for p in out.iterdir()) == [".straight.lock"]


@pytest.mark.parametrize("address, why", [("127.0.0.1:1", "no Ray cluster answers there"),
                                          ("bogus", "give local, auto or HOST:PORT")])
def test_a_ray_address_where_no_cluster_answers_is_one_line_at_once(tmp_path, capsys,
                                                                     monkeypatch, address, why):
    """It retried for ever, and the Ray example with it."""
    out = tmp_path / "out"
    start = time.perf_counter()
    monkeypatch.setenv("RAY_ADDRESS", address)
    assert cli.main(["benchmark", "straight", "--protocol", str(tiny_protocol(tmp_path)), "--out",
                     str(out), "--workers", "ray"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Ray address" in err and address in err and why in err

    assert time.perf_counter() - start < 30 and not out.exists()


def test_the_leaderboard_refuses_a_smoke_result_in_one_line(tmp_path, capsys):
    result = json.loads((ROOT / "docs/benchmark/runs/straight/result.json").read_text())
    result["protocol"]["smoke"] = True
    (tmp_path / "straight").mkdir()
    (tmp_path / "straight" / "result.json").write_text(json.dumps(result))
    assert cli.main(["leaderboard", str(tmp_path / "straight"), "--out",
                     str(tmp_path / "b.md")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "a smoke result" in err and "not ranked" in err


@pytest.mark.slow  # a smoke run of a tiny protocol: about 15 s
def test_benchmark_smoke_writes_a_smoke_result(tmp_path, capsys):
    tiny = tiny_protocol(tmp_path, episodes="episodes = 5")
    out = tmp_path / "out"
    assert cli.main(["benchmark", "straight", "--smoke", "--protocol", str(tiny), "--out",
                     str(out), "--workers", "1", "--no-progress"]) == 0
    assert "(a smoke result: not a row)" in capsys.readouterr().out
    result = json.loads((out / "straight" / "result.json").read_text())
    assert result["protocol"]["smoke"] is True
    assert len(result["parts"]["goal"]["seeds"]) == protocol.SMOKE_SEEDS  # of the file's 5


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """lgmd1 and Straight through the tiny protocol."""
    tmp = tmp_path_factory.mktemp("bench")
    tiny = tiny_protocol(tmp)
    out = tmp / "out"
    assert _benchmark(tiny, out, "lgmd1", "straight") == 0
    return tiny, out


@pytest.mark.slow  # whole benchmarks of a tiny protocol: 15-50 s each
def test_a_benchmark_writes_every_track_s_scores_with_intervals(tiny_run):
    _, out = tiny_run
    result = json.loads((out / "lgmd1-published" / "result.json").read_text())
    assert set(result["scores"]) == {"goal", "arena", "detection", "overall"}
    for key, value in result["scores"].items():
        low, high = result["intervals"][key]
        assert 0 <= low <= value <= high <= 1
    assert result["entry"]["params"]["threshold"] > 0
    assert result["protocol"]["version"] == 1
    straight = json.loads((out / "straight" / "result.json").read_text())
    assert "detection" not in straight["scores"]
    for track in ("goal", "arena"):  # the bench's tables, not figures no page shows
        made = {p.name for p in (out / "lgmd1-published" / track).iterdir()}
        assert {"episodes.csv", "summary.csv", "summary.md", "run.json"} <= made
        assert not [name for name in made if name.endswith(".png")], made
