"""A plug-in model is the researcher's code, run by every command: whatever it does wrong
(writing into its input frames, potentials that are NaN or out of range, raising in its
constructor or its step, calling sys.exit, a parameter named like one of the base's) ends
the command with one line naming the plug-in, exit status 2, and nothing left behind; and
no plug-in can change what the other models of a run see."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import cli, models
from lgmd_sim.models import ModelCheckError, PluginError, check_model

PLUGINS = Path(__file__).parent / "plugins"
QUIET = ["--workers", "1", "--no-progress"]


@pytest.fixture(autouse=True)
def plugins(monkeypatch):
    """tests/plugins on sys.path: the faulty plug-ins are tests/plugins/hostile.py."""
    monkeypatch.syspath_prepend(str(PLUGINS))


@pytest.fixture
def video(approach):
    """The approach's video (conftest's)."""
    return approach[0]


def _one_line(capsys, *names: str) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for name in names:
        assert name in err, err
    return err


# --- one frame for every model -----------------------------------------------------------


def test_a_plug_in_cannot_change_the_frame_every_model_reads():
    frame = np.random.default_rng(0).integers(0, 256, (24, 32), np.uint8)
    kept = frame.copy()
    model = models.make("hostile:Mutating")
    with pytest.raises(PluginError, match="writes into its input frames, which are read-only"):
        model.step(frame)
    np.testing.assert_array_equal(frame, kept)
    for name in models.available():  # the built-ins read the same frames and keep to them
        models.make(name, n_streams=2).step(np.stack([frame, frame]))
    np.testing.assert_array_equal(frame, kept)


def test_detect_refuses_a_plug_in_that_writes_into_its_frames(video, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["detect", str(video), "--models", "lgmd1,hostile:Mutating,lgmd2",
                     "--out", str(out), "--no-progress"]) == 2
    _one_line(capsys, "hostile:Mutating", "read-only")
    assert not out.exists() or not list(out.iterdir())


def test_check_model_names_the_mutation():
    with pytest.raises(ModelCheckError) as exc:
        check_model("hostile:Mutating")
    assert "potentials: step_batch: it writes into its input frames" in str(exc.value)
    assert "unseeded random numbers" not in str(exc.value)


# --- potentials, in every command --------------------------------------------------------


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
                     "--seeds", "1", "--resolution", "small", "--presets-file", str(presets),
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


# --- a plug-in's own errors --------------------------------------------------------------


@pytest.mark.parametrize(("plugin", "message"), [
    ("StepBoom", "plug-in model hostile:StepBoom: step_batch: raised RuntimeError: boom in step"),
    ("Exits", "plug-in model hostile:Exits: step_batch: it called sys.exit(3)"),
    ("InitBoom", "plug-in model hostile:InitBoom: __init__: raised RuntimeError: boom in init"),
])
def test_detect_names_the_plug_in_whose_code_failed(video, tmp_path, capsys, plugin, message):
    assert cli.main(["detect", str(video), "--models", f"lgmd1,hostile:{plugin}", "--out",
                     str(tmp_path / "out"), "--no-progress"]) == 2
    assert _one_line(capsys) == f"lgmd-sim detect: error: {message}"


BENCHES = {
    "closed-loop": ["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter", "0",
                    "--controllers", "reactive", "--seeds", "1", "--resolution", "small",
                    "--models"],
    "open-loop": ["bench", "open-loop", "--scenarios", "HandheldApproach", "--jitter", "1",
                  "--seeds", "1", "--resolution", "small", "--noise-levels", "", "--models"],
    "calibrate": ["calibrate", "--budget", "2", "--seeds", "1", "--resolution", "small",
                  "--detectors"],
    "dataset": ["dataset", "generate", "--scenarios", "StationaryApproach", "--episodes", "1",
                "--resolution", "small", "--models"],
}


@pytest.mark.parametrize("command", BENCHES)
@pytest.mark.parametrize("plugin", ["InitBoom", "StepBoom", "Exits"])
def test_a_failing_plug_in_leaves_no_run_folder(tmp_path, capsys, command, plugin):
    out = tmp_path / "run"
    assert cli.main([*BENCHES[command], f"hostile:{plugin}", *QUIET, "--out", str(out)]) == 2
    _one_line(capsys, f"hostile:{plugin}/plain: ")
    assert not out.exists()


def test_a_plug_in_s_error_crosses_from_a_worker_whole():
    error = PluginError("hostile:LateBoom", "step_batch", "raised RuntimeError: boom late")
    again = pickle.loads(pickle.dumps(error))
    assert isinstance(again, PluginError) and str(again) == str(error) == (
        "plug-in model hostile:LateBoom: step_batch: raised RuntimeError: boom late")


def test_lgmd_sim_s_own_refusals_pass_through_a_plug_in_unchanged():
    with pytest.raises(ValueError) as exc:
        models.make("lgmd_plug:NoMaps", preset="plain+image")
    assert not isinstance(exc.value, PluginError)
    assert str(exc.value).startswith("nomaps lists no state maps")


def test_a_spec_naming_no_class_is_one_short_line(capsys):
    assert cli.main(["models", "--check", "os:__builtins__"]) == 2
    err = _one_line(capsys, "os:__builtins__", "a dict is not a subclass of")
    assert len(err) < 200


# --- the base's parameter names ----------------------------------------------------------


def test_a_parameter_named_like_the_base_s_is_refused_naming_it():
    with pytest.raises(ModelCheckError) as exc:
        check_model("hostile:Shadow")
    text = str(exc.value)
    assert "parameters: parameter gain is the base class's" in text
    for name in models.RESERVED_PARAMETERS:
        assert name in text
    assert "must be a finite number" not in text
    with pytest.raises(PluginError, match="parameter gain is the base class's"):
        models.make("hostile:Shadow")  # else its gain of 2.0 would turn the front end on


@pytest.mark.usefixtures("examples_on_path")
def test_the_reserved_names_are_the_base_s_but_threshold():
    assert set(models.RESERVED_PARAMETERS) == {
        "stabilize", "fovy", "gain", "alarm_frames", "alarm_rising", "working_height"}
    eta = json.dumps(check_model("eta_lgmd:EtaLGMD"))  # redeclares threshold: allowed
    assert "parameters" in eta
