"""The curriculum of `lgmd-sim train` (a --config key): stages passed at their success
rate, each recorded, the training environments built with each stage's parameters
(validation with the task's), resuming at the stage the checkpoint names, and bad stages
refused in one line."""

from __future__ import annotations

import json
import time

import pytest

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import cli
from lgmd_sim.core import fileio
from lgmd_sim.training import curriculum, curve
from lgmd_sim.training import envs as training_envs

from train_tiny import config_option

# Frameless (privileged) episodes of the goal task: steps of well under a millisecond.
ENV = "lgmd_sim/RoughTerrainObstacles-v0"
TINY = ["train", "--obs", "privileged", "--env", ENV, "--envs", "1", "--hp", "n_steps=64",
        "--hp", "batch_size=64", "--no-progress"]
# The goal within its radius from the start: every episode succeeds on its first step.
AT_THE_GOAL = "n_obstacles = 0\ngoal_distance = 0.8\ngoal_radius = 1.0\n"


def _tiny(tmp_path, **keys) -> list[str]:
    """TINY with a --config file in `tmp_path` holding `keys` and its validation and
    checkpoint intervals."""
    return [*TINY, *config_option(tmp_path / "tiny.toml", {
        "eval_every": 128, "eval_seeds": 1, "checkpoint_every": 128, **keys})]


def _stages(tmp_path, *tables: str, window: int = 2):
    path = tmp_path / "stages.toml"
    path.write_text(f"window = {window}\n" + "".join(f"[[stage]]\n{t}\n" for t in tables))
    return path


@pytest.fixture
def built(monkeypatch):
    """The parameters each training or validation VecEnv is built with, in order."""
    calls = []
    make = training_envs.make_vec_env

    def recording(config, n_envs, overrides=None):
        calls.append(dict(overrides or {}))
        return make(config, n_envs, overrides)

    monkeypatch.setattr(training_envs, "make_vec_env", recording)
    return calls


@pytest.mark.slow
def test_the_curriculum_advances_and_each_stage_is_recorded(tmp_path, built):
    stages = _stages(tmp_path, AT_THE_GOAL + "jitter = 0.5\nadvance_at = 1.0",
                     AT_THE_GOAL + "advance_at = 0.5")
    out = tmp_path / "run"
    assert cli.main([*_tiny(tmp_path, curriculum=str(stages), reward=["goal_bonus=2"]),
                     "--steps", "256", "--out", str(out)]) == 0
    first = {"n_obstacles": 0, "goal_distance": 0.8, "goal_radius": 1.0}
    # training stage 1, validation (the task), stage 2, then the task itself; the reward
    # shaping in every training stage
    assert built == [{"goal_bonus": 2.0, **first, "jitter": 0.5}, {},
                     {"goal_bonus": 2.0, **first}, {"goal_bonus": 2.0}]
    record = json.loads((out / "run.json").read_text())
    assert record["curriculum"] == {"window": 2, "stage": [
        {**first, "jitter": 0.5, "advance_at": 1.0}, {**first, "advance_at": 0.5}]}
    (session,) = record["sessions"]
    rows = session["stages"]
    assert [(r["stage"], r["passed"]) for r in rows] == [(0, True), (1, True), (2, False)]
    assert rows[0]["success_rate"] == 1.0 and rows[0]["episodes"] == 2
    # a stage passed mid-rollout drops the rollout; the last one ends the budget
    assert rows[0]["steps"][0] == 0 and 256 <= rows[-1]["steps"][1] < 256 + 64
    assert rows[0]["overrides"] == {**first, "jitter": 0.5} and rows[2]["overrides"] == {}
    assert rows[0]["steps"][1] == rows[1]["steps"][0] < rows[1]["steps"][1] == rows[2]["steps"][0]
    assert session["env_seeds"] == [0, 3]  # fresh seeds for each stage's environment
    assert curve.phase_changes(out) == [(rows[0]["steps"][1], "stage 1 passed"),
                                        (rows[1]["steps"][1], "stage 2 passed")]
    assert json.loads((out / "checkpoints" / "state.json").read_text())["stage"] == 2
    summary = (out / "summary.md").read_text()
    assert f"Curriculum {stages}" in summary and "| 0 | task | the task's |" in summary


@pytest.mark.slow
def test_resume_keeps_the_curriculum_stage(tmp_path, built):
    # stage 2 is never passed: its goal is the task's, 8 m away
    stages = _stages(tmp_path, AT_THE_GOAL + "advance_at = 1.0", "advance_at = 1.0")
    out = tmp_path / "run"
    assert cli.main([*_tiny(tmp_path, curriculum=str(stages)), "--steps", "128",
                     "--out", str(out)]) == 0
    assert json.loads((out / "checkpoints" / "state.json").read_text())["stage"] == 1
    built.clear()
    assert cli.main(["train", "--resume", str(out), "--steps", "256", "--no-progress"]) == 0
    assert built[0] == {}  # stage 2 has no parameters of its own; not stage 1's
    record = json.loads((out / "run.json").read_text())
    assert [[r["stage"] for r in s["stages"]] for s in record["sessions"]] == [[0, 1], [1]]
    assert record["sessions"][1]["stages"][0]["steps"][1] >= 256

    stages.write_text(stages.read_text().replace("advance_at = 1.0", "advance_at = 0.9"))
    assert cli.main(["train", "--resume", str(out), "--steps", "384"]) == 2


def test_the_built_in_curriculum_fits_the_main_task():
    stages = curriculum.load("obstacles", ENV).stages
    assert [s.overrides["n_obstacles"] for s in stages] == [0, 2, 4]
    assert all(0 < s.advance_at <= 1 for s in stages)


@pytest.mark.parametrize(("text", "message"), [
    ("[[stage]]\nwarp = 1\nadvance_at = 0.5\n", "stage 1: unknown parameter(s) warp"),
    ("[[stage]]\nn_obstacles = 1\n", "stage 1: advance_at must be a success rate"),
    ("[[stage]]\nresolution = 'paper'\nadvance_at = 0.5\n", "resolution cannot change"),
    ("[[stage]]\nmax_speed = 2.0\nadvance_at = 0.5\n", "max_speed cannot change"),
    ("[[stage]]\ngoal_bonus = 2.0\nadvance_at = 0.5\n", "every stage with the reward key"),
    ("[[stage]]\nn_obstacles = -1\nadvance_at = 0.5\n", "stage 1: EnvParams: parameter n_obs"),
    ("window = 0\n[[stage]]\nadvance_at = 0.5\n", "needs a positive integer `window`"),
    ("[[stage\n", "nor a readable TOML file"),
    # stages that are not tables: an AttributeError traceback before
    ("stage = [1, 2]\n", "stage 1 is int, not a table of parameters"),
    ("stage = [{advance_at = 0.5}, 'fast']\n", "stage 2 is str, not a table of parameters"),
    # TOML's booleans are no numbers
    ("[[stage]]\nadvance_at = true\n", "stage 1: advance_at must be a success rate"),
    ("window = true\n[[stage]]\nadvance_at = 0.5\n", "needs a positive integer `window`"),
])
def test_a_bad_curriculum_is_one_line_before_training(tmp_path, capsys, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    out = tmp_path / "never"
    assert cli.main([*_tiny(tmp_path, curriculum=str(path)), "--steps", "64",
                     "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert err.startswith(f"lgmd-sim train: error: {tmp_path / 'tiny.toml'}: curriculum "), err
    assert not out.exists()


@pytest.mark.parametrize("kind", ["/dev/zero", "a file past the limit"])
def test_a_curriculum_file_too_large_to_be_one_is_refused_in_one_line_quickly(tmp_path, capsys,
                                                                               kind):
    # /dev/zero was read until the kernel killed the process
    if kind == "/dev/zero":
        path = "/dev/zero"
    else:
        path = tmp_path / "huge.toml"
        with open(path, "wb") as f:  # sparse: no disk, no time
            f.truncate(fileio.TEXT_LIMIT + 1)
    out = tmp_path / "never"
    start = time.perf_counter()
    assert cli.main([*_tiny(tmp_path, curriculum=str(path)), "--steps", "64",
                     "--out", str(out)]) == 2
    assert time.perf_counter() - start < 30
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err, err
    assert ("not a regular file" if kind == "/dev/zero" else "larger than") in err, err
    assert not out.exists()
