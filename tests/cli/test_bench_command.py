"""`lgmd-sim bench closed-loop` and `open-loop`: identical results on 1 and 2 workers and on
Ray, resuming, refusals, and bad input caught before any episode runs; the open loop's
tables, noise and figures."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from lgmd_sim import cli, models

#: --config files of the commands' research keys.
KEYS = Path(__file__).parent / "keys"
#: bench open-loop without the noisy copies of the clips.
NO_NOISE = ["--config", str(KEYS / "no-noise.toml")]

# A fast sweep: the tripod scenario at 64 x 64 (about 0.2 s an episode); the machinery
# is the same as on the robot.


# A fast sweep: the tripod scenario at 64 x 64 (about 0.2 s an episode); the machinery
# is the same as on the robot.
SWEEP = ["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter", "0,1",
         "--controllers", "straight,oracle,reactive", "--models", "lgmd1,feedback",
         "--seeds", "2", "--resolution", "small", "--no-progress"]


TABLES = ("episodes.csv", "summary.csv", "summary.md")


OPEN = ["bench", "open-loop", "--scenarios", "StationaryApproach,PassBy", "--jitter", "0",
        "--models", "lgmd1,feedback", "--seeds", "1", "--resolution", "small",
        "--config", str(KEYS / "one-noise.toml"), "--workers", "1", "--no-progress"]


def _bench(out, *extra: str) -> int:
    return cli.main([*SWEEP, "--out", str(out), *extra])


@pytest.mark.slow
def test_two_workers_give_the_same_results(one_worker, tmp_path):
    out = tmp_path / "two"
    assert _bench(out, "--workers", "2") == 0
    for name in TABLES:
        assert (out / name).read_bytes() == (one_worker / name).read_bytes(), name


@pytest.mark.slow
def test_ray_gives_the_same_results(one_worker, tmp_path):
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        out = tmp_path / "ray"
        assert _bench(out, "--workers", "ray") == 0
    finally:
        ray.shutdown()
    for name in TABLES:
        assert (out / name).read_bytes() == (one_worker / name).read_bytes(), name


@pytest.mark.slow
def test_resume_keeps_finished_episodes_and_refuses_other_runs(one_worker, tmp_path, capsys):
    import shutil

    out = tmp_path / "resumed"
    shutil.copytree(one_worker, out)
    records = sorted((out / "records").iterdir())
    records[3].unlink()  # as if the run had been killed before this episode finished
    for name in TABLES:
        (out / name).unlink()
    kept = records[0].stat().st_mtime_ns
    assert _bench(out, "--workers", "1") == 2  # not without --resume
    assert "--resume" in capsys.readouterr().err
    assert _bench(out, "--workers", "1", "--resume") == 0
    assert records[0].stat().st_mtime_ns == kept  # not run again
    run = json.loads((out / "run.json").read_text())
    first = json.loads((one_worker / "run.json").read_text())
    assert run["command"] == first["command"]  # the command that started the run
    assert [s["command"] for s in run["sessions"]] == [first["command"], run["sessions"][1][
        "command"]] and "--resume" in run["sessions"][1]["command"]
    assert run["wall_time_s"] == pytest.approx(sum(s["wall_time_s"] for s in run["sessions"]),
                                               abs=0.2)
    for name in TABLES:
        assert (out / name).read_bytes() == (one_worker / name).read_bytes(), name
    capsys.readouterr()
    assert _bench(out, "--seeds", "3", "--resume") == 2  # the last --seeds wins
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "seeds" in err and "another configuration" in err


def test_a_run_whose_preset_changed_since_is_not_resumed(one_worker, tmp_path, capsys,
                                                         monkeypatch):
    import shutil


    out = tmp_path / "recalibrated"
    shutil.copytree(one_worker, out)
    recorded = json.loads((out / "run.json").read_text())["config"]["detector_params"]
    assert recorded["lgmd1/published"]["threshold"] == models.make("lgmd1").params.threshold
    shipped = models.presets_of

    def recalibrated(name):  # lgmd1's default preset with another threshold
        own = shipped(name)
        return {**own, "published": {**own["published"], "threshold": 0.91}} if (
            name == "lgmd1") else own

    monkeypatch.setattr(models, "presets_of", recalibrated)
    assert _bench(out, "--workers", "1", "--resume") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "detector_params.lgmd1/published.threshold" in err


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--models", "lgmd9", "lgmd9"),
    ("--models", "feedback/nope", "unknown preset 'nope'"),
    ("--controllers", "pilot", "unknown controller(s) 'pilot'"),
    ("--scenarios", "Moon", "unknown scenario(s) 'Moon'"),
    ("--jitter", "0,9", "--jitter must hold jitter levels in [0, 5], got '9'"),
    ("--jitter", "x", "--jitter must hold jitter levels in [0, 5], got 'x'"),
    ("--presets", "nope", "no model listed has any of the presets nope"),
])
def test_bad_input_is_one_line_before_any_episode(tmp_path, capsys, option, value, message):
    out = tmp_path / "never"
    assert _bench(out, option, value) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not out.exists()


def test_zero_seeds_is_refused(tmp_path):
    with pytest.raises(SystemExit) as exc:
        cli.main([*SWEEP, "--seeds", "0", "--out", str(tmp_path / "x")])
    assert exc.value.code == 2


@pytest.mark.slow
def test_open_loop_tables_noise_and_figures(tmp_path):
    out = tmp_path / "open"
    assert cli.main([*OPEN, "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "summary.csv").open()))
    # 2 scenarios x (clean + gaussian + salt-and-pepper) x 2 detectors
    assert len(rows) == 2 * 3 * 2
    assert {r["noise"] for r in rows} == {"", "gaussian:0.005", "saltpepper:0.005"}
    approach = [r for r in rows if r["scenario"] == "StationaryApproach"]
    near_miss = [r for r in rows if r["scenario"] == "PassBy"]
    assert all(r["hit_rate"] != "" and r["false_alarm_rate"] == "" for r in approach)
    assert all(r["false_alarm_rate"] != "" and r["hit_rate"] == "" for r in near_miss)
    for r in rows:
        assert 0 <= float(r["auc"]) <= 1 and float(r["mpsi"]) >= 1
    clean = {r["detector"]: r for r in approach if not r["noise"]}
    assert float(clean["lgmd1/published"]["si"]) < 1  # it crosses before collision
    for name in ("summary.md", "noise.md", "detection_curves.png", "noise.png",
                 "clip_StationaryApproach_j0.png", "clip_PassBy_j0.png"):
        assert (out / name).stat().st_size > 500, name


@pytest.mark.slow
def test_open_loop_on_a_dataset_equals_the_simulated_clips(tmp_path):
    pytest.importorskip("pyarrow")
    data = tmp_path / "data"
    assert cli.main(["dataset", "generate", "--scenarios", "StationaryApproach", "--jitter",
                     "0", "--episodes", "1", "--resolution", "small", "--out", str(data),
                     "--workers", "1", "--no-progress"]) == 0
    base = ["bench", "open-loop", "--models", "lgmd1", *NO_NOISE, "--workers", "1",
            "--no-progress"]
    assert cli.main([*base, "--dataset", str(data), "--out", str(tmp_path / "a")]) == 0
    assert cli.main([*base, "--scenarios", "StationaryApproach", "--jitter", "0", "--seeds",
                     "1", "--resolution", "small", "--out", str(tmp_path / "b")]) == 0
    a = list(csv.DictReader((tmp_path / "a" / "summary.csv").open()))
    b = list(csv.DictReader((tmp_path / "b" / "summary.csv").open()))
    assert a == b  # lossless frames: the same potentials, the same table


def test_open_loop_runs_detectors_with_front_ends(tmp_path):
    out = tmp_path / "front"
    assert cli.main(["bench", "open-loop", "--scenarios", "HandheldApproach", "--jitter", "1",
                     "--seeds", "1", "--models", "lgmd1,lgmd1/published+pose",
                     "--resolution", "small", *NO_NOISE, "--workers", "1",
                     "--no-progress", "--out", str(out)]) == 0
    rows = {r["detector"]: r for r in csv.DictReader((out / "summary.csv").open())}
    assert set(rows) == {"lgmd1/published", "lgmd1/published+pose"}
    assert rows["lgmd1/published"]["mpsi"] != rows["lgmd1/published+pose"]["mpsi"]


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "one"
    assert _bench(out, "--workers", "1") == 0
    return out


@pytest.mark.slow
def test_a_sweep_writes_every_cell_and_episode(one_worker):
    rows = list(csv.DictReader((one_worker / "episodes.csv").open()))
    cells = {(r["jitter"], r["controller"], r["model"]) for r in rows}
    assert len(rows) == 2 * 4 * 2 and len(cells) == 8  # jitters x (2 + 2 detectors) x seeds
    assert {r["seed"] for r in rows} == {"1000", "1001"}
    straight = [r for r in rows if r["controller"] == "straight"]
    assert all(r["collided"] == "True" for r in straight)  # the balloon hits the tripod
    summary = list(csv.DictReader((one_worker / "summary.csv").open()))
    assert len(summary) == 8
    for r in summary:
        assert float(r["collision_ci_low"]) <= float(r["collision_rate"]) <= float(
            r["collision_ci_high"])
    run = json.loads((one_worker / "run.json").read_text())
    assert run["status"] == "complete" and run["config"]["seeds"] == [1000, 2]
    assert "lgmd-sim bench closed-loop" in run["command"]  # after any PYTHONPATH=
    for name in ("collisions_vs_jitter.png", "false_alarms_vs_collisions.png"):
        assert (one_worker / name).stat().st_size > 10_000
