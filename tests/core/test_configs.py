"""The jobs' typed configurations and the one run folder: checked where they are made, the
same from Python as from the command line, and the folder's guarantees for every job."""

from __future__ import annotations

import argparse
import json

import pytest

from lgmd_sim import cli
from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
from lgmd_sim.benchmark.open_loop import OpenLoopConfig
from lgmd_sim.calibration.run import CalibrateConfig
from lgmd_sim.cli import bench as cli_bench
from lgmd_sim.controllers import options
from lgmd_sim.core.runs import RunFolder


def _parsed(*argv: str):
    args = cli.build_parser().parse_args(list(argv))
    args.command_line = "test"
    return args


def test_the_command_makes_the_config_python_would(tmp_path):
    args = _parsed("bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter",
                   "0,1,1", "--models", "lgmd1/calibrated+image,feedback", "--seeds", "3")
    assert cli_bench.closed_loop_config(args) == ClosedLoopConfig(
        scenarios=("StationaryApproach",), jitter=(0, 1), seeds=3,
        detectors=(("lgmd1", "calibrated+image"), ("feedback", "paper")))
    keys = tmp_path / "keys.toml"
    keys.write_text("noise_levels = []\nseeds = 5\nwindow = 0.5\n")
    args = _parsed("bench", "open-loop", "--config", str(keys), "--seeds", "2")
    assert cli_bench.open_loop_config(args) == OpenLoopConfig(seeds=2, noise_levels=(),
                                                              window=0.5)


@pytest.mark.parametrize(("make", "message"), [
    (lambda: ClosedLoopConfig(jitter=(9.0,)), "jitter must hold jitter levels in [0, 5]"),
    (lambda: ClosedLoopConfig(jitter=(1.0, 1.0)), "jitter must hold each level once"),
    (lambda: ClosedLoopConfig(cruise=2.0), "cruise must be a number in [-1, 1], got 2.0"),
    (lambda: ClosedLoopConfig(horizon=float("nan")), "horizon must be a finite number > 0"),
    (lambda: ClosedLoopConfig(seeds=0), "seeds must be an integer >= 1, got 0"),
    (lambda: ClosedLoopConfig(top_views=0), "top_views must be an integer >= 1, got 0"),
    (lambda: ClosedLoopConfig(controllers=("pilot",)), "unknown controller(s) 'pilot'"),
    (lambda: ClosedLoopConfig(detectors=(("lgmd1", "nope"),)), "unknown preset 'nope'"),
    (lambda: ClosedLoopConfig(resolution="huge"), "resolution must be"),
    (lambda: OpenLoopConfig(noise_levels=(2.0,)), "noise_levels must hold noise levels in (0, 1]"),
    (lambda: OpenLoopConfig(window=-1.0), "window must be a finite number >= 0, got -1.0"),
    (lambda: CalibrateConfig(detectors=("lgmd9",)), "unknown detector(s) 'lgmd9'"),
    (lambda: CalibrateConfig(heldout_seed=3), "the search and held-out seeds overlap"),
])
def test_a_bad_value_fails_where_the_config_is_made(make, message):
    with pytest.raises(ValueError) as exc:
        make()
    assert message in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("spelling", ["270x480", "270X480"])
def test_every_config_takes_the_resolution_as_the_command_line_spells_it(spelling):
    from lgmd_sim.cli.args import resolution
    from lgmd_sim.data.generate import GenerateConfig

    # the API refused the CLI's spelling
    assert resolution(spelling) == options.resolution(spelling) == (270, 480)
    for make in (ClosedLoopConfig, OpenLoopConfig, CalibrateConfig,
                 lambda **kw: GenerateConfig(("PassBy",), (1.0,), 1, **kw)):
        assert make(resolution=spelling) == make(resolution=[270, 480])
    pytest.importorskip("stable_baselines3")
    from lgmd_sim.training.run import TrainConfig

    assert TrainConfig(obs="privileged", resolution=spelling).resolution == (270, 480)


def test_a_bad_resolution_is_the_same_line_from_python_and_the_command_line():
    from lgmd_sim.cli.args import resolution

    with pytest.raises(argparse.ArgumentTypeError) as on_the_command_line:
        resolution("270by480")
    with pytest.raises(ValueError) as in_python:
        ClosedLoopConfig(resolution="270by480")
    message = str(on_the_command_line.value)
    assert str(in_python.value) == f"resolution {message}"
    assert "HEIGHTxWIDTH" in message and "'270by480'" in message and "\n" not in message


@pytest.mark.parametrize(("option", "value"), [
    ("hp", 5), ("hp", [5]), ("reward", "goal_bonus=1"), ("env", 5), ("algo", ["ppo"]),
    ("curriculum", 5),  # open() took it for a file descriptor
])
def test_a_training_option_of_the_wrong_type_is_one_line_naming_it(option, value):
    # as a hand-edited run.json brings it when resumed: a traceback before
    pytest.importorskip("stable_baselines3")
    from lgmd_sim.training.run import TrainConfig

    with pytest.raises(ValueError) as exc:
        TrainConfig(obs="privileged", **{option: value})
    # the error names the field (the command line names its option instead)
    assert str(exc.value).startswith(f"{option} ") and "\n" not in str(exc.value)


def test_the_shared_parsers():
    assert options.jitter_levels("0, 1,0") == (0.0, 1.0)
    assert options.names("all", ["a", "b"], "x") == ["a", "b"]
    assert options.detectors("lgmd1", "calibrated,nope") == (("lgmd1", "calibrated"),)
    with pytest.raises(ValueError, match=r"jitter must hold jitter levels in .*, got 'x'"):
        options.jitter_levels("1,x")
    with pytest.raises(ValueError, match="no model listed has any of the presets nope"):
        options.detectors("lgmd1", "nope")


def test_a_run_folder_keeps_sessions_and_refuses_another_run(tmp_path):
    out = tmp_path / "run"
    first = RunFolder(out, {"a": 1, "steps": 10}, "first", changeable=("steps",))
    first.store("k", {"x": 1})
    first.finish(done=1)
    with pytest.raises(ValueError, match="already holds this run: add --resume"):
        RunFolder(out, {"a": 1, "steps": 10}, "again")
    with pytest.raises(ValueError, match="another configuration: a is 1 there, 2 here"):
        RunFolder(out, {"a": 2, "steps": 10}, "other", resume=True)
    second = RunFolder(out, {"a": 1, "steps": 20}, "second", resume=True,
                       changeable=("steps",))
    assert second.done() == {"k"} and second.records() == [{"x": 1}]
    second.finish()
    record = json.loads((out / "run.json").read_text())
    assert record["command"] == "first" and record["config"]["steps"] == 20
    assert [s["command"] for s in record["sessions"]] == ["first", "second"]
    assert record["status"] == "complete" and record["done"] == 1
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "x").write_text("")
    with pytest.raises(ValueError, match="is not empty and holds no run"):
        RunFolder(tmp_path / "other", {}, "c")


def test_a_run_folder_with_an_identity_file_writes_it_once(tmp_path):
    out = tmp_path / "ds"
    RunFolder(out, {"b": [1, 2]}, "c", resume=True, record="meta/run.json",
              identity="meta/config.json").finish()
    identity = (out / "meta" / "config.json").read_bytes()
    RunFolder(out, {"b": [1, 2]}, "d", resume=True, record="meta/run.json",
              identity="meta/config.json").finish()
    assert (out / "meta" / "config.json").read_bytes() == identity
    assert not (out / "records").exists()  # no job stored a record
    with pytest.raises(ValueError, match="b is 1,2 there, 1,3 here"):
        RunFolder(out, {"b": [1, 3]}, "e", resume=True, record="meta/run.json",
                  identity="meta/config.json")
