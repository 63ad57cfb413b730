"""A plug-in that does wrong, run by a command (detect, the benches, calibrate, dataset):
one line naming the plug-in, exit status 2, nothing left behind."""

from __future__ import annotations

from pathlib import Path

import pytest

from lgmd_sim import cli

#: --config files of the commands' research keys.
KEYS = Path(__file__).parent / "keys"
#: bench open-loop without the noisy copies of the clips.
NO_NOISE = ["--config", str(KEYS / "no-noise.toml")]

# the faulty plug-ins are tests/plugins/hostile.py
pytestmark = pytest.mark.usefixtures("test_plugins_on_path")


@pytest.fixture
def video(approach):
    """The approach's video (conftest's)."""
    return approach[0]


QUIET = ["--workers", "1", "--no-progress"]


def _one_line(capsys, *names: str) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for name in names:
        assert name in err, err
    return err


BENCHES = {
    "closed-loop": ["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter", "0",
                    "--controllers", "reactive", "--seeds", "1", "--resolution", "small",
                    "--models"],
    "open-loop": ["bench", "open-loop", "--scenarios", "HandheldApproach", "--jitter", "1",
                  "--seeds", "1", "--resolution", "small", *NO_NOISE, "--models"],
    "calibrate": ["calibrate", "--budget", "2", "--seeds", "1", "--resolution", "small",
                  "--detectors"],
    "dataset": ["dataset", "generate", "--scenarios", "StationaryApproach", "--episodes", "1",
                "--resolution", "small", "--models"],
}


def test_detect_refuses_a_plug_in_that_writes_into_its_frames(video, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["detect", str(video), "--models", "lgmd1,hostile:Mutating,lgmd2",
                     "--out", str(out), "--no-progress"]) == 2
    _one_line(capsys, "hostile:Mutating", "read-only")
    assert not out.exists() or not list(out.iterdir())


@pytest.mark.parametrize(("plugin", "fault"), [
    ("NaNs", "potential nan of stream 0 is not finite"),
    ("Huge", "potential 5e+29 of stream 0 is outside the range the alarm threshold takes"),
    ("WrongShape", "step_batch returned an array of float64 of shape (3,), not a float array "
                   "of shape (1,)"),
])
def test_detect_refuses_potentials_the_contract_does_not_allow(video, tmp_path, capsys,
                                                                plugin, fault):
    assert cli.main(["detect", str(video), "--models", f"lgmd1,hostile:{plugin}", "--out",
                     str(tmp_path / "out"), "--no-progress"]) == 2
    err = _one_line(capsys, f"plug-in model hostile:{plugin}: potentials: ", fault)
    assert "sensitivity_index" not in err and "broadcast" not in err


@pytest.mark.parametrize("plugin", ["NaNs", "Huge"])
def test_calibrate_refuses_bad_potentials_and_writes_no_preset(tmp_path, capsys, plugin):
    out, presets = tmp_path / "cal", tmp_path / "presets.json"
    assert cli.main(["calibrate", "--detectors", f"hostile:{plugin}", "--budget", "2",
                     "--seeds", "1", "--resolution", "small", "--save-presets", str(presets),
                     *QUIET, "--out", str(out)]) == 2
    _one_line(capsys, f"hostile:{plugin}/plain: potentials: potential")
    assert not out.exists() and not presets.exists()


def test_closed_loop_bench_refuses_bad_potentials_before_any_episode(tmp_path, capsys):
    out = tmp_path / "closed"
    assert cli.main(["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter",
                     "0", "--controllers", "reactive", "--models", "hostile:Huge", "--seeds",
                     "1", "--resolution", "small", *QUIET, "--out", str(out)]) == 2
    _one_line(capsys, "hostile:Huge/plain: potentials: potential 5e+29")
    assert not out.exists()


@pytest.mark.parametrize(("plugin", "message"), [
    ("StepBoom", "plug-in model hostile:StepBoom: step_batch: raised RuntimeError: boom in step"),
    ("Exits", "plug-in model hostile:Exits: step_batch: it called sys.exit(3)"),
    ("InitBoom", "plug-in model hostile:InitBoom: __init__: raised RuntimeError: boom in init"),
])
def test_detect_names_the_plug_in_whose_code_failed(video, tmp_path, capsys, plugin, message):
    assert cli.main(["detect", str(video), "--models", f"lgmd1,hostile:{plugin}", "--out",
                     str(tmp_path / "out"), "--no-progress"]) == 2
    assert _one_line(capsys) == f"lgmd-sim detect: error: {message}"


@pytest.mark.parametrize("command", BENCHES)
@pytest.mark.parametrize("plugin", ["InitBoom", "StepBoom", "Exits"])
def test_a_failing_plug_in_leaves_no_run_folder(tmp_path, capsys, command, plugin):
    out = tmp_path / "run"
    assert cli.main([*BENCHES[command], f"hostile:{plugin}", *QUIET, "--out", str(out)]) == 2
    _one_line(capsys, f"hostile:{plugin}/plain: ")
    assert not out.exists()


def test_a_spec_naming_no_class_is_one_short_line(capsys):
    assert cli.main(["models", "--check", "os:__builtins__"]) == 2
    err = _one_line(capsys, "os:__builtins__", "a dict is not a subclass of")
    assert len(err) < 200
