"""docs/experiments/tools/collision_views.py: a collision replayed from a benchmark run's records,
the obstacle it hits found in the camera's frames before it."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

from lgmd_sim.core.parallel import RunOptions

# The research log's tools (docs/experiments/tools/): the slow tier, out of the edit loop.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[4]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


def test_a_wall_driven_into_is_seen_ahead_and_a_replay_that_differs_is_left_out(tmp_path):
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig, run

    bench = tmp_path / "bench"
    # Straight at the wall of RobotWallAhead, seeds 0 and 1: both end against it.
    run(ClosedLoopConfig(scenarios=("RobotWallAhead",), jitter=(0.0,),
                         controllers=("straight",), seeds=2, first_seed=0),
        bench, RunOptions(workers=1, progress=False))
    with (bench / "episodes.csv").open(newline="") as f:
        records = list(csv.DictReader(f))
    assert [r["collided"] for r in records] == ["True", "True"]
    records[1]["frames"] = str(int(records[1]["frames"]) - 3)  # as if played otherwise
    with (bench / "episodes.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, list(records[0]))
        writer.writeheader()
        writer.writerows(records)

    out = tmp_path / "views"
    subprocess.run([sys.executable, str(TOOLS / "collision_views.py"), str(bench),
                    str(out), "--workers", "1"], check=True, capture_output=True)
    with (out / "collisions.csv").open(newline="") as f:
        (row,) = csv.DictReader(f)  # the replay that ended elsewhere is left out
    assert row["seed"] == "0" and row["arena_wall"] == "False" and row["threat"] == "0"
    for lag in ("0.25", "0.5", "1"):
        assert int(row[f"pixels_{lag}s"]) > 1000  # the wall fills much of the frame
        # ahead (the nearest point to the chassis's corner, beside the camera's axis)
        assert abs(float(row[f"bearing_{lag}s"])) < 45
    table = (out / "collision_views.md").read_text()
    assert "| 0 | straight | 2 | 2 | 1 | 0 | 0 (0%) | 0 (0%) | 0 (0%) | 0 (0%) |" in table
    assert (out / "collision_views.png").stat().st_size > 0


def test_a_loom_steer_collision_keeps_what_its_detector_said_before_it(tmp_path):
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig, run
    from lgmd_sim.benchmark.episode import Cell

    bench = tmp_path / "bench"
    # LoomSteer on LGMD1 that cannot steer nor slow: whatever its detector says, it drives
    # into the wall of RobotWallAhead.
    blind = Cell("RobotWallAhead", 0.0, "loom-steer", "lgmd1", "robot-image",
                 params=(("steer_gain", 0.0), ("slow", 0.0), ("avoid_turn", 0.0),
                         ("avoid_speed", 0.6)), tag="blind")
    run(ClosedLoopConfig(scenarios=("RobotWallAhead",), jitter=(0.0,), controllers=(),
                         extra=(blind,), seeds=1, first_seed=0),
        bench, RunOptions(workers=1, progress=False))
    out = tmp_path / "views"
    subprocess.run([sys.executable, str(TOOLS / "collision_views.py"), str(bench),
                    str(out), "--workers", "1"], check=True, capture_output=True)
    with (out / "collisions.csv").open(newline="") as f:
        (row,) = csv.DictReader(f)
    excitation = [float(row[f"excitation_{lag}s"]) for lag in ("0.25", "0.5", "1")]
    assert all(0.0 <= x <= 2.0 for x in excitation) and len(set(excitation)) > 1
    alarmed = int(row["alarms_last_2s"]) > 0
    shown = " | ".join(f"{x:.2f} ({x:.2f})" for x in excitation)
    assert (f"| 0 | loom-steer: lgmd1/robot-image (blind) | 1 | {shown} | {int(alarmed)} "
            f"({100 * alarmed}%) |"
            in (out / "collision_views.md").read_text())


@pytest.mark.parametrize("scenario, collided, says", [
    ("ArenaRoam", True, "holds ArenaRoam, whose episodes go on after a collision: only "
                        "scenarios that end at one"),
    ("RobotWallAhead", False, "records no collision to replay"),
])
def test_a_run_it_cannot_replay_is_refused_in_one_line(tmp_path, scenario, collided, says):
    import json

    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    config = ClosedLoopConfig(scenarios=(scenario,), jitter=(1.0,), controllers=("straight",),
                              seeds=1)
    (tmp_path / "run.json").write_text(json.dumps({"config": config.as_json()}))
    (tmp_path / "episodes.csv").write_text(
        "scenario,jitter,controller,model,preset,tag,side,seed,task,frames,collided\n"
        f"{scenario},1.0,straight,,,,,1000,roam,900,{collided}\n")
    done = subprocess.run([sys.executable, str(TOOLS / "collision_views.py"),
                           str(tmp_path), str(tmp_path / "views")], capture_output=True,
                          text=True)
    assert (done.returncode, done.stderr) == (1, f"collision_views.py: {tmp_path} {says}\n")
    assert not (tmp_path / "views").exists()


def _bad(folder: Path, case: str) -> tuple[list[str], Path, str]:
    """A run folder in `folder` broken as `case` says: the tool's arguments, its output
    folder and what its one line must name."""
    import json

    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    run, out = folder / "run", folder / "views"
    run.mkdir()
    config = ClosedLoopConfig(scenarios=("RobotWallAhead",), jitter=(1.0,),
                              controllers=("straight",), seeds=1).as_json()
    if case == "plug-in not on the path":
        config.update(controllers=["reactive"], detectors=[["no_such_plugin:Detector", "x"]])
    record = {"config": config}
    (run / "run.json").write_text({"run.json not JSON": "{",
                                   "run.json of a training run": '{"config": {"algo": "ppo"}}',
                                   }.get(case, json.dumps(record)))
    (run / "episodes.csv").write_text(
        "scenario,jitter,controller,model,preset,tag,side,seed,task,frames,collided\n"
        "RobotWallAhead,1.0,straight,,,,,1000,goal,"
        f"{'many' if case == 'episodes.csv corrupt' else '90'},True\n")
    args, names = [str(run), str(out)], str(run / "run.json")
    if case == "missing folder":
        args[0] = names = str(folder / "nowhere")
    elif case == "folder without run.json":
        (run / "run.json").unlink()
    elif case in ("--workers 0", "--workers -1"):
        args += case.split()
        names = "--workers must be an integer >= 1"
    elif case == "--out a file":
        out.write_text("kept")
        names = f"output folder {out} is a file"
    elif case == "--out inside a file":
        (folder / "file").write_text("kept")
        out = folder / "file" / "views"
        args[1] = names = str(out)
    elif case == "plug-in not on the path":
        names = "no_such_plugin:Detector"
    elif case == "episodes.csv missing":
        (run / "episodes.csv").unlink()
        names = str(run / "episodes.csv")
    elif case == "episodes.csv corrupt":
        names = f"{run / 'episodes.csv'}, line 2"
    return args, out, names


@pytest.mark.parametrize("case", [
    "missing folder", "folder without run.json", "run.json not JSON",
    "run.json of a training run", "--workers 0", "--workers -1", "--out a file",
    "--out inside a file", "plug-in not on the path", "episodes.csv missing",
    "episodes.csv corrupt"])
def test_a_bad_input_is_one_line_naming_it_and_leaves_nothing(tmp_path, case):
    args, out, names = _bad(tmp_path, case)
    done = subprocess.run([sys.executable, str(TOOLS / "collision_views.py"), *args],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode != 0 and done.stdout == ""
    assert done.stderr.startswith("collision_views.py: ") and done.stderr.count("\n") == 1
    assert names in done.stderr and "Traceback" not in done.stderr
    # nothing written: no output folder, and a file in its place kept as it was
    assert (out.read_text() == "kept") if out.is_file() else not out.exists()
