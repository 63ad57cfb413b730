"""What a run reads that a user may have changed or got wrong: a run folder's records
(a bench or calibration record with other content, truncated, not JSON), a training run's
record, checkpoint state and policies, training hyperparameters of the wrong type, and the
words of the help texts and the missing-extra hint. Each is refused in one line naming the
thing, before any work starts."""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import pytest

from lgmd_sim import cli
from lgmd_sim.core import fileio
from lgmd_sim.core.runs import RunFolder
from lgmd_sim.training.config import TrainConfig

#: --config files of the commands' research keys.
KEYS = Path(__file__).parent / "keys"
#: bench open-loop without the noisy copies of the clips.
NO_NOISE = ["--config", str(KEYS / "no-noise.toml")]

# One episode, one clip: the machinery of a full run, in seconds.
CLOSED = ["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter", "0",
          "--controllers", "straight", "--seeds", "1", "--resolution", "small",
          "--workers", "1", "--no-progress"]
OPEN = ["bench", "open-loop", "--scenarios", "StationaryApproach", "--jitter", "0",
        "--models", "lgmd1", "--seeds", "1", "--resolution", "small", *NO_NOISE,
        "--workers", "1", "--no-progress"]
CALIBRATE = ["calibrate", "--detectors", "lgmd1", "--budget", "1", "--seeds", "1",
             "--resolution", "small", "--workers", "1", "--no-progress"]


def _made(tmp_path_factory, argv: list[str]):
    out = tmp_path_factory.mktemp("run") / "done"
    assert cli.main([*argv, "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def closed(tmp_path_factory):
    return _made(tmp_path_factory, CLOSED)


@pytest.fixture(scope="module")
def opened(tmp_path_factory):
    return _made(tmp_path_factory, OPEN)


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    return _made(tmp_path_factory, CALIBRATE)


def _one_line_naming(capsys, path) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err, err
    return err


def _resume_with(done, tmp_path, capsys, argv, record: str, text: str) -> str:
    """Resume a copy of the finished run `done` whose record `record` holds `text`: refused
    in one line naming that record."""
    out = tmp_path / "copy"
    shutil.copytree(done, out)
    (bad,) = (out / "records").glob(record)
    bad.write_text(text)
    assert cli.main([*argv, "--out", str(out), "--resume"]) == 2
    return _one_line_naming(capsys, bad)


def _truncated(done, record: str) -> str:
    (file,) = (done / "records").glob(record)
    return file.read_text()[:50]


def _without(done, record: str, *path: str | int) -> str:
    """The record with the field at `path` (keys and list indices) removed."""
    (file,) = (done / "records").glob(record)
    data = json.loads(file.read_text())
    holder = data
    for step in path[:-1]:
        holder = holder[step]
    del holder[path[-1]]
    return json.dumps(data)


@pytest.mark.parametrize("text", [
    '{"scenario": "x"}',  # the case: a KeyError traceback
    "[]",
    '{"scenario": "StationaryApproach", "jitter": 0, "controller": "straight", "model": null,'
    ' "preset": null, "seed": 1000, "frames": 3, "time_s": 0.1, "collided": "yes",'
    ' "goal_reached": false, "false_alarms": 0, "first_alarm_ttc_s": null,'
    ' "lead_time_s": null}',  # every field, one of the wrong type
    None,  # truncated: the message did not name the file
])
def test_a_closed_loop_record_that_is_not_one_is_refused_naming_it(closed, tmp_path, capsys,
                                                                    text):
    record = "StationaryApproach-j0-straight-s1000.json"
    err = _resume_with(closed, tmp_path, capsys, CLOSED, record,
                       _truncated(closed, record) if text is None else text)
    assert "remove it" in err


@pytest.mark.parametrize("path", [("rows",), ("rows", 0, "detector"), ("collision_frame",),
                                  None])
def test_an_open_loop_record_that_is_not_one_is_refused_naming_it(opened, tmp_path, capsys,
                                                                   path):
    record = "StationaryApproach-j0-s0.json"
    text = _truncated(opened, record) if path is None else _without(opened, record, *path)
    _resume_with(opened, tmp_path, capsys, OPEN, record, text)


@pytest.mark.parametrize(("record", "path"), [
    ("clip-PassBy-j0-s0.json", None),
    ("clip-PassBy-j0-s0.json", ("kind",)),
    ("lgmd1-000.json", ("sets",)),
    ("lgmd1-000.json", None),
])
@pytest.mark.slow
def test_a_calibration_record_that_is_not_one_is_refused_naming_it(calibrated, tmp_path,
                                                                    capsys, record, path):
    text = _truncated(calibrated, record) if path is None else _without(calibrated, record,
                                                                         *path)
    _resume_with(calibrated, tmp_path, capsys, CALIBRATE, record, text)


def test_a_resumed_run_with_good_records_still_completes(closed, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(closed, out)
    assert cli.main([*CLOSED, "--out", str(out), "--resume"]) == 0
    assert (out / "summary.csv").read_bytes() == (closed / "summary.csv").read_bytes()


@pytest.mark.parametrize("text", ['{"config": [1]}', '{"config": {}, "sessions": "x"}', "[]"])
def test_a_run_record_of_another_shape_is_one_line_naming_it(tmp_path, text):
    (tmp_path / "run.json").write_text(text)
    with pytest.raises(ValueError, match=r"run\.json") as exc:
        RunFolder(tmp_path, {"a": 1}, "cmd", resume=True)
    assert "\n" not in str(exc.value)


def test_a_run_of_an_older_lgmd_sim_is_refused_in_one_line_that_says_to_rerun(
        closed, tmp_path, capsys):
    """run.json carries its schema; a run folder written before it (or by another schema)
    is not converted: resuming it is one line naming the file and saying to run it again."""
    from lgmd_sim.core.runs import SCHEMA

    out = tmp_path / "old"
    shutil.copytree(closed, out)
    record = json.loads((out / "run.json").read_text())
    assert record["schema"] == SCHEMA
    del record["schema"]  # as an older lgmd-sim wrote it
    (out / "run.json").write_text(json.dumps(record))
    assert cli.main([*CLOSED, "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(out / "run.json") in err
    assert "record schema 1" in err and "run it again into a new folder" in err
    assert (out / "summary.csv").read_bytes() == (closed / "summary.csv").read_bytes()


def test_an_identity_file_of_another_shape_is_one_line_naming_it(tmp_path):
    (tmp_path / "config.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"config\.json"):
        RunFolder(tmp_path, {"a": 1}, "cmd", resume=True, identity="config.json")


# --- a training run's own files --------------------------------------------------------------

# A training run as resuming reads it: its record and its checkpoint's state.json (a state
# that passes gets as far as loading the checkpoint, which is not there).
TRAINING = {"schema": 2,
            "config": TrainConfig(obs="privileged", model=None,
                                  env="lgmd_sim/StationaryApproach-v0", resolution="small",
                                  envs=1, steps=64, hp=("n_steps=64",)).as_json(),
            "sessions": [{"env_seeds": [0, 1], "steps": [0, 64]}]}


def _training_run(tmp_path, record=TRAINING, state='{"num_timesteps": 64}'):
    out = tmp_path / "run"
    (out / "checkpoints").mkdir(parents=True)
    (out / "run.json").write_text(json.dumps(record))
    state_file = out / "checkpoints" / "state.json"
    if state is None:  # past the size limit; sparse: no disk, no time
        with open(state_file, "wb") as f:
            f.truncate(fileio.TEXT_LIMIT + 1)
    else:
        state_file.write_text(state)
    return out


def _resume_training(out, capsys, named) -> str:
    before = (out / "run.json").read_bytes()
    assert cli.main(["train", "--resume", str(out), "--steps", "128", "--no-progress"]) == 2
    assert (out / "run.json").read_bytes() == before  # no session started
    return _one_line_naming(capsys, named)


@pytest.mark.parametrize("state", [
    "[]", '{"num_timesteps": "64"}', '{"steps": 64}', '{"num_timesteps": 64, "stage": -1}',
    '{"num_timesteps": 64, "stage": true}', None])
def test_a_checkpoint_state_that_is_not_one_is_refused_naming_it(tmp_path, capsys, state):
    pytest.importorskip("stable_baselines3")
    out = _training_run(tmp_path, state=state)
    err = _resume_training(out, capsys, out / "checkpoints" / "state.json")
    assert "cannot be resumed" in err or "larger than" in err


@pytest.mark.parametrize("session", [
    {},  # no env_seeds: a KeyError traceback
    {"env_seeds": [0, 1], "stages": "none"},
    {"env_seeds": [0, 1], "imitation": [{"round": 0}]},
    {"env_seeds": [0, 1], "throughput": {"ratio": "fast"}},
])
def test_a_training_record_of_another_shape_is_refused_before_resuming(tmp_path, capsys,
                                                                        session):
    pytest.importorskip("stable_baselines3")
    out = _training_run(tmp_path, {**TRAINING, "sessions": [session]})
    _resume_training(out, capsys, out / "run.json")


def test_the_summary_and_the_curve_refuse_files_of_another_shape_naming_them(tmp_path):
    from lgmd_sim.training import curve, summary

    out = _training_run(tmp_path, {**TRAINING, "sessions": [
        {"env_seeds": [0, 1], "value_warmup": {"steps": "64"}}]})
    for read in (curve.phase_changes, summary.summary_markdown):
        with pytest.raises(ValueError) as exc:
            read(out)
        assert str(out / "run.json") in str(exc.value) and "\n" not in str(exc.value)
    (out / "best").mkdir()
    (out / "best" / "policy.json").write_text('{"trained": {"validation": {"step": 64}}}')
    with pytest.raises(ValueError) as exc:
        summary.validation_rows(out)
    assert str(out / "best" / "policy.json") in str(exc.value) and "\n" not in str(exc.value)


# --- hyperparameters ------------------------------------------------------------------------


@pytest.mark.parametrize(("algo", "item", "message"), [
    ("ppo", "learning_rate=abc", "learning_rate=abc: ppo's learning_rate must be a number"),
    ("ppo", "batch_size=1.5", "batch_size=1.5: ppo's batch_size must be an integer"),
    ("ppo", "gamma=x", "gamma=x: ppo's gamma must be a number"),
    ("ppo", "n_steps=True", "n_steps=True: ppo's n_steps must be an integer"),
    ("ppo", "policy_kwargs=[64]", "policy_kwargs=[64]: ppo's policy_kwargs must be"),
    ("ppo", "normalize_advantage=1", "normalize_advantage=1: ppo's normalize_advantage"),
    ("sac", "train_freq=(1,2)", "train_freq=(1,2): sac's train_freq must be"),
    ("sac", "ent_coef=[0.1]", "ent_coef=[0.1]: sac's ent_coef must be"),
    ("ppo", "warp=9", "unknown hyperparameter 'warp' for ppo"),
    ("ppo", "device='cuda'", "unknown hyperparameter 'device' for ppo"),  # the run sets it
    # policy.json holds policy_kwargs: JSON has no sets, and makes every key a string
    ("ppo", "policy_kwargs={'net_arch': {8}}", "ppo's policy_kwargs must be JSON"),
    ("sac", "policy_kwargs={'net_arch': {'pi': [8], 1: [8]}}",
     "sac's policy_kwargs must be JSON"),
])
def test_a_hyperparameter_of_the_wrong_type_is_refused_naming_it(algo, item, message):
    pytest.importorskip("stable_baselines3")
    from lgmd_sim.training.algos import parse_overrides

    with pytest.raises(ValueError) as exc:
        parse_overrides([item], algo)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_good_hyperparameters_are_taken_as_given():
    pytest.importorskip("stable_baselines3")
    from lgmd_sim.training.algos import parse_overrides

    assert parse_overrides(["learning_rate=3e-4", "batch_size=64", "clip_range_vf=None",
                            "policy_kwargs={'net_arch': [32, 32]}", "gamma=1"], "ppo") == {
        "learning_rate": 3e-4, "batch_size": 64, "clip_range_vf": None,
        "policy_kwargs": {"net_arch": [32, 32]}, "gamma": 1}
    assert parse_overrides(["ent_coef=auto_0.1", "train_freq=(1, 'episode')",
                            "target_entropy=-2.0"], "sac") == {
        "ent_coef": "auto_0.1", "train_freq": (1, "episode"), "target_entropy": -2.0}


@pytest.mark.parametrize(("hp", "message"), [
    ("learning_rate=abc", "learning_rate=abc"),
    # the right type, a value stable-baselines3, PyTorch or the policy refuses
    ("batch_size=1", "batch_size"),
    ("learning_rate=-1", "learning rate"),
    ("policy_kwargs={'foo': 1}", "foo"),
    # a network stable-baselines3 builds, that policy.json cannot hold: refused before training
    ("policy_kwargs={'net_arch': {8}}", "policy_kwargs"),
])
def test_train_refuses_bad_hyperparameters_in_one_line_leaving_no_folder(tmp_path, capsys, hp,
                                                                         message):
    pytest.importorskip("stable_baselines3")
    out = tmp_path / "never"
    assert cli.main(["train", "--env", "lgmd_sim/StationaryApproach-v0", "--resolution",
                     "small", "--envs", "1", "--steps", "64", "--hp", "n_steps=64", "--hp", hp,
                     "--no-progress", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and "--hp" in err, err
    assert not out.exists()


# --- words a user reads ---------------------------------------------------------------------


def _parsers(parser: argparse.ArgumentParser, name: str = "lgmd-sim"):
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, p in action.choices.items():
                yield from _parsers(p, f"{name} {sub}")


def test_every_help_text_prints_its_percent_signs_once():
    from lgmd_sim.cli import build_parser

    texts = {name: p.format_help() for name, p in _parsers(build_parser())}
    assert "lgmd-sim bench closed-loop" in texts and "lgmd-sim dataset generate" in texts
    assert "95% Wilson" in " ".join(texts["lgmd-sim bench closed-loop"].split())
    assert not [name for name, text in texts.items() if "%%" in text]


def test_train_help_says_it_needs_the_rl_extra_and_how_to_install_it():
    import subprocess

    text = " ".join(subprocess.run([sys.executable, "-m", "lgmd_sim.cli", "train", "--help"],
                                   capture_output=True, text=True, check=True).stdout.split())
    assert "Needs the rl extra" in text
    # argparse may wrap the help at the hyphen of lgmd-sim
    assert ("from a checkout of lgmd-sim: pip install -c constraints.txt '.[rl]'"
            in text.replace("lgmd- sim", "lgmd-sim"))


def test_the_missing_extra_hint_is_a_command_that_works_from_a_checkout(monkeypatch):
    from lgmd_sim.core.extras import MissingExtra, require

    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # as if not installed
    with pytest.raises(MissingExtra) as exc:
        require("stable_baselines3", "rl")
    message = str(exc.value)
    assert "'rl' extra" in message and "lgmd-sim[" not in message
    assert "from a checkout of lgmd-sim: pip install -c constraints.txt '.[rl]'" in message


@pytest.mark.parametrize("how, why", [({"workers": 0}, "workers must be an integer >= 1"),
                                      ({"workers": True}, "workers must be an integer >= 1"),
                                      ({"ray_address": "127.0.0.1:1"}, "no Ray cluster"),
                                      ({"ray_address": "nowhere"}, "give local, auto")])
def test_how_the_jobs_run_is_refused_when_it_is_made(how, why):
    """Every job that keeps a run folder takes a RunOptions: a bad `workers` or a Ray
    address where nothing answers is refused when the options are made, so that no job
    can start (nor make its folder) with them."""
    from lgmd_sim.core.parallel import RunOptions

    with pytest.raises(ValueError, match=why):
        RunOptions(**how)


def test_every_job_takes_how_it_runs_as_one_run_options():
    """One RunOptions instead of the tail (workers, ray_address, progress, resume, command)
    each job's signature repeated."""
    import inspect

    from lgmd_sim.benchmark import closed_loop, open_loop, run, verify
    from lgmd_sim.calibration.run import calibrate
    from lgmd_sim.core.parallel import RunOptions, run_jobs
    from lgmd_sim.data.generate import generate
    from lgmd_sim.training.evaluate import evaluate

    jobs = [closed_loop.run, open_loop.run, calibrate, generate, evaluate, run.benchmark,
            run.calibrated, verify.verify, run_jobs]
    for job in jobs:
        parameters = inspect.signature(job).parameters
        assert parameters["options"].annotation in (RunOptions, "RunOptions"), job
        assert not {"workers", "ray_address", "progress", "resume", "command"} & set(parameters)
