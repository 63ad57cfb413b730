"""`lgmd-sim train` and `lgmd-sim eval`: a tiny run end to end, the saved policy acting as
in training (same observations, frozen normalisation, deterministic), resuming, the
shipped policy, and bad input refused in one line before anything starts."""

from __future__ import annotations

import csv
import itertools
import json
import shutil
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import cli, controllers, policies
from lgmd_sim.policies import folder as policy_lib
from lgmd_sim.policies.observe import PixelObservation, base_env, observe
from lgmd_sim.training.envs import make_vec_env

# The tripod scenario at 64 x 64: episodes of a few seconds, steps of a few ms; the
# machinery is the robot's.
ENV = "lgmd_sim/StationaryApproach-v0"
TINY = ["train", "--algo", "ppo", "--env", ENV, "--resolution", "small", "--hp", "n_steps=64",
        "--hp", "batch_size=64", "--eval-every", "128", "--eval-seeds", "2",
        "--checkpoint-every", "128", "--no-progress"]


def _train(out, *extra: str) -> int:
    return cli.main([*TINY, "--out", str(out), *extra])


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("train") / "tiny"
    assert _train(out, "--steps", "256") == 0
    return out


@pytest.mark.slow
def test_a_tiny_run_goes_end_to_end(run):
    for name in ("policy.npz", "policy.json", "best/policy.npz", "best/policy.json",
                 "summary.md", "checkpoints/model.zip", "checkpoints/vecnormalize.pkl"):
        assert (run / name).is_file(), name
    assert (run / "learning_curve.png").stat().st_size > 10_000
    record = json.loads((run / "run.json").read_text())
    assert record["status"] == "complete"
    (session,) = record["sessions"]
    assert "lgmd-sim train --algo ppo" in session["command"]
    assert session["env_seeds"] == [0, 2] and session["steps"][0] == 0
    assert {"stable-baselines3", "torch", "lgmd-sim"} <= set(session["versions"])
    assert session["throughput"]["bare_vec_env_steps_per_s"] > 0
    assert record["seeds"]["validation"] == [900, 2]
    assert json.loads((run / "checkpoints" / "state.json").read_text())["num_timesteps"] >= 256
    rows = list(csv.DictReader((run / "logs" / "session-0" / "progress.csv").open()))
    evals = [r for r in rows if r.get("eval/success_rate")]
    assert [int(r["time/total_timesteps"]) for r in evals] == [128, 256]
    assert all(float(r["eval/collision_rate"]) == 1.0 for r in evals)  # the balloon hits
    assert list((run / "logs" / "session-0").glob("events.out.tfevents.*"))
    trained = json.loads((run / "policy.json").read_text())
    assert trained["config"]["model"] == "feedback" and trained["normalize"]["mean"]
    assert trained["trained"]["steps"] == 256


def test_the_policy_acts_deterministically_on_what_it_was_trained_to_see(run):
    from stable_baselines3.common.vec_env import VecNormalize

    policy = controllers.make("policy", path=str(run))
    config = policy.policy.config
    env = policy.wrap_env(base_env(config))

    def actions(seed: int) -> list[list[float]]:
        return [s.action.tolist() for s in controllers.rollout(env, policy, seed=seed)
                if s.action is not None]

    first = actions(5)
    assert len(first) > 10 and actions(5) == first
    # the frozen statistics are the checkpoint's VecNormalize's, applied the same way
    stats = VecNormalize.load(str(run / "checkpoints" / "vecnormalize.pkl"),
                              make_vec_env(config, 1).venv)
    obs, _ = env.reset(seed=6)
    ours = policy.policy.normalize(obs)
    theirs = stats.normalize_obs({k: v[None] for k, v in obs.items()})
    for key in obs:
        np.testing.assert_array_equal(ours[key], theirs[key][0])
    stats.close()
    env.close()


def test_the_s_layer_grid_its_history_and_memory_are_options_the_policy_keeps(tmp_path):
    out = tmp_path / "grid"
    assert _train(out, "--steps", "64", "--envs", "1", "--grid", "2x4",
                  "--grid-history", "3", "--memory", "30") == 0
    config = json.loads((out / "policy.json").read_text())["config"]
    assert (config["grid"], config["grid_history"], config["memory"]) == ([2, 4], 3, 30)
    policy = controllers.make("policy", path=str(out))
    env = policy.wrap_env(base_env(policy.policy.config))
    obs, _ = env.reset(seed=1)
    assert obs["lgmd_grid"].shape == (24,)
    assert obs["lgmd_memory"].shape == (4,)  # a column each
    env.close()
    assert ("S-layer grid 2x4 over the last 3 frames with a 30-frame memory"
            in (out / "summary.md").read_text())


def test_the_training_vec_env_observes_as_the_controller_does(run):
    """The batched LGMD features of the training VecEnv are those of the single wrapped
    environment the controller sees, bit for bit."""
    config = policy_lib.load_config(run)[1]
    envs = make_vec_env(config, 1)
    envs.venv.seed(3)
    batched = envs.venv.reset()
    single = observe(base_env(config), config)
    obs, _ = single.reset(seed=3)
    action = np.array([0.5, 0.2], np.float32)
    for _ in range(5):
        assert set(obs) == set(batched) and "frame" not in obs
        for key in obs:
            np.testing.assert_array_equal(obs[key], batched[key][0])
        batched, *_ = envs.venv.step(action[None])
        obs, *_ = single.step(action)
    envs.close()
    single.close()


def test_reward_shaping_reaches_the_training_environments_only(tmp_path, monkeypatch):
    from lgmd_sim.training import envs as training_envs

    built = []

    def recording(config, n_envs, overrides=None):
        vec = make_vec_env(config, n_envs, overrides)
        built.append({k: getattr(vec.base.get_attr("params")[0], k)
                      for k in ("goal_bonus", "time_penalty", "collision_penalty")})
        return vec

    monkeypatch.setattr(training_envs, "make_vec_env", recording)
    out = tmp_path / "shaped"
    assert _train(out, "--steps", "64", "--envs", "1", "--reward", "goal_bonus=5",
                  "--reward", "time_penalty=0.5") == 0
    shaped, validation = built
    assert shaped == {"goal_bonus": 5.0, "time_penalty": 0.5, "collision_penalty": 10.0}
    assert validation == {"goal_bonus": 0.0, "time_penalty": 0.0, "collision_penalty": 10.0}
    record = json.loads((out / "run.json").read_text())
    assert record["config"]["reward"] == ["goal_bonus=5", "time_penalty=0.5"]
    assert "training reward goal_bonus=5, time_penalty=0.5" in (out / "summary.md").read_text()
    assert cli.main(["train", "--resume", str(out), "--steps", "128",
                     "--reward", "goal_bonus=1"]) == 2  # not an option a resume changes


@pytest.mark.slow
def test_resume_continues_the_step_count(run, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(run, out)
    # as a run recorded before --grid and --value-warmup existed: it ran at their defaults
    record = json.loads((out / "run.json").read_text())
    for key in ("grid", "value_warmup"):
        del record["config"][key]
    (out / "run.json").write_text(json.dumps(record))
    assert cli.main(["train", "--resume", str(out), "--steps", "384", "--no-progress"]) == 0
    record = json.loads((out / "run.json").read_text())
    assert [s["steps"] for s in record["sessions"]] == [[0, 256], [256, 384]]
    assert record["sessions"][1]["env_seeds"] == [2, 2]  # not the first session's episodes
    assert json.loads((out / "checkpoints" / "state.json").read_text())["num_timesteps"] == 384
    assert json.loads((out / "policy.json").read_text())["trained"]["steps"] == 384
    rows = list(csv.DictReader((out / "logs" / "session-1" / "progress.csv").open()))
    assert min(int(r["time/total_timesteps"]) for r in rows) > 256


@pytest.mark.slow
@pytest.mark.parametrize("obs", ["pixels", "privileged"])
def test_validation_plays_the_episodes_eval_plays_on_its_seeds(tmp_path, obs):
    """Two validation environments play seeds 900 and 901 as the policy's controller does
    alone (`lgmd-sim eval`): the same distance travelled, to the last digit (a batch of
    observations rounds the CNN's actions differently, and the robot drives on them; a
    vector policy's actions come from `lgmd_sim.policies.forward` on both sides)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from lgmd_sim.training.callbacks import run_episodes
    from lgmd_sim.training.envs import normalized_keys

    out = tmp_path / obs
    assert _train(out, "--obs", obs, "--env", "lgmd_sim/RoughTerrainObstacles-v0",
                  "--steps", "64", "--envs", "1", "--eval-seeds", "1") == 0
    policy = controllers.make("policy", path=str(out))
    config = policy.policy.config
    short = {"time_limit": 3.0}
    alone = []
    for seed in (900, 901):
        env = policy.wrap_env(base_env(config, **short))
        steps = list(controllers.rollout(env, policy, seed=seed))
        alone.append(sum(float(np.linalg.norm(np.subtract(b.info["carrier_pos"][:2],
                                                           a.info["carrier_pos"][:2])))
                         for a, b in itertools.pairwise(steps)))
        env.close()
    envs = make_vec_env(config, 2, short)
    stats = VecNormalize.load(str(out / "checkpoints" / "vecnormalize.pkl"), envs.venv)
    envs.venv = VecNormalize(envs.venv, training=False, norm_reward=False,
                             norm_obs_keys=normalized_keys(envs.venv, obs))
    envs.venv.obs_rms = stats.obs_rms
    model = PPO.load(out / "checkpoints" / "model.zip", device="cpu")
    try:
        validated = [e["distance_m"] for e in run_episodes(model, envs, [900, 901])]
    finally:
        envs.close()
    assert min(alone) > 0 and validated == alone


def test_pixels_stack_small_grey_frames_channels_first():
    env = PixelObservation(gym.make(ENV, resolution="small"), size=(36, 48), stack=3)
    obs, _ = env.reset(seed=0)
    assert obs["frame"].shape == (3, 36, 48) and obs["frame"].dtype == np.uint8
    assert (obs["frame"] == obs["frame"][0]).all()  # no motion before the first step
    first = obs["frame"][-1]
    obs, *_ = env.step(np.zeros(2, np.float32))
    np.testing.assert_array_equal(obs["frame"][1], first)  # oldest first
    assert "proprio" in obs
    env.close()


@pytest.mark.slow
def test_eval_runs_the_policy_beside_the_hand_made_controllers(run, tmp_path, capsys):
    out = tmp_path / "eval"
    assert cli.main(["eval", str(run), str(run / "best"), "--controllers", "straight,reactive",
                     "--models", "lgmd1", "--jitter", "1", "--seeds", "1", "--workers", "1",
                     "--out", str(out), "--no-progress"]) == 0
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert {(r["controller"], r["tag"] or r["model"]) for r in rows} == {
        ("policy", "tiny"), ("policy", "tiny-best"), ("straight", ""), ("reactive", "lgmd1")}
    assert {r["seed"] for r in rows} == {"1000"}
    table = (out / "eval.md").read_text()
    assert "| 1 | policy: tiny |" in table and "reactive: lgmd1/published (best detector)" in table
    assert json.loads((out / "run.json").read_text())["config"]["resolution"] == "small"
    for name in ("summary.md", "collisions_vs_jitter.png", "trajectories.png"):
        assert (out / name).is_file()


def test_eval_by_default_runs_reactive_with_the_detector_the_policy_observes_and_draws_seeds(
        run):
    from lgmd_sim.cli import build_parser
    from lgmd_sim.cli.eval import config_from_args

    _, trained, _ = policy_lib.load_config(run)
    config = config_from_args(build_parser().parse_args(["eval", str(run)]))
    assert config.detectors is None and config.seeds == policies.EVAL_SEEDS
    assert config.bench().detectors == ((trained.model, trained.preset),)
    assert config.bench().top_views == policies.EVAL_TOP_VIEWS > 1  # beside the Oracle
    given = config_from_args(build_parser().parse_args(["eval", str(run), "--models", "lgmd2"]))
    assert [m for m, _ in given.bench().detectors] == ["lgmd2"]


def test_the_shipped_policy_acts_in_its_environment():
    assert policies.DEFAULT in policies.available()
    folder, config, data = policy_lib.load_config("shipped")
    assert folder == policies.path(policies.DEFAULT) and (folder / "POLICY.md").is_file()
    assert "lgmd-sim train" in data["trained"]["command"]
    policy = controllers.make("policy")  # the default path: the shipped policy
    env = policy.wrap_env(base_env(config))
    obs, info = env.reset(seed=1000)
    action = policy.act(obs, info)
    assert action.shape == (2,) and np.isfinite(action).all()
    env.close()


def test_a_policy_refuses_another_frame_size(run):
    policy = controllers.make("policy", path=str(run))
    with pytest.raises(ValueError, match="trained on 64x64 frames"):
        policy.wrap_env(gym.make(ENV, resolution="rl"))


def _nan_reward_env(**overrides):
    class NanReward(gym.Wrapper):
        def step(self, action):
            obs, _, terminated, truncated, info = self.env.step(action)
            return obs, float("nan"), terminated, truncated, info

    from lgmd_sim.envs import JitterEnv

    return NanReward(JitterEnv("StationaryApproach", **overrides))


@pytest.mark.parametrize(("args", "message"), [
    (["--algo", "a2c"], "unknown algorithm 'a2c'"),
    (["--obs", "rgb"], "unknown observation 'rgb'"),
    (["--model", "lgmd9"], "unknown model 'lgmd9'"),
    (["--preset", "nope"], "unknown preset 'nope'"),
    (["--env", "lgmd_sim/Moon-v0"], "unknown environment id 'lgmd_sim/Moon-v0'"),
    (["--steps", "0"], "--steps must be a positive integer, got 0"),
    (["--hp", "warp=9"], "unknown hyperparameter 'warp'"),
    (["--reward", "jitter=2"], "--reward 'jitter=2': not KEY=VALUE with KEY one of"),
    (["--reward", "goal_bonus=lots"], "--reward goal_bonus=lots: 'lots' is not a number"),
    (["--reward", "goal_bonus=-5"], "parameter goal_bonus=-5.0 must be"),
    (["--reward", "goal_bonus=1", "--reward", "goal_bonus=2"], "--reward goal_bonus is given "
     "twice"),
    (["--env", "lgmd_test/NanReward-v0", "--envs", "1"], "is not finite"),
    (["--obs", "pixels", "--grid", "2x2"], "--grid is the S-layer grid of --obs features, "
     "not pixels"),
    (["--obs", "privileged", "--grid-history", "2"], "--grid-history is of --obs features"),
    (["--grid-history", "0"], "--grid-history must be a positive integer, got 0"),
    (["--memory", "-1"], "--memory must be a non-negative integer (frames), got -1"),
    (["--obs", "pixels", "--memory", "30"], "--memory is of --obs features"),
])
def test_bad_input_is_one_line_before_training(tmp_path, capsys, args, message):
    if "lgmd_test/NanReward-v0" not in gym.registry:
        gym.register("lgmd_test/NanReward-v0", entry_point=_nan_reward_env)
    out = tmp_path / "never"
    assert _train(out, "--steps", "64", *args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()


def test_folders_holding_another_run_or_no_checkpoint_are_refused(run, tmp_path, capsys):
    assert _train(run, "--steps", "64") == 2  # the folder holds a run
    assert f"add --resume {run}" in capsys.readouterr().err
    bare = tmp_path / "bare"
    shutil.copytree(run, bare)
    shutil.rmtree(bare / "checkpoints")
    assert cli.main(["train", "--resume", str(bare)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no checkpoint" in err
    assert cli.main(["train", "--resume", str(run), "--algo", "sac"]) == 2
    assert "--algo sac differs" in capsys.readouterr().err


def test_a_missing_rl_extra_is_one_line_naming_it(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # as if not installed
    for argv in (["train", "--out", str(tmp_path / "x"), "--steps", "64"],
                 ["eval", "--out", str(tmp_path / "y")]):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "'rl' extra" in err


def test_ship_policy_releases_a_runs_best_policy_with_its_rows(run, tmp_path, monkeypatch):
    import importlib
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "docs/experiments/tools"))
    ship_policy = importlib.import_module("ship_policy")
    monkeypatch.setattr(ship_policy, "POLICIES", tmp_path / "policies")
    out = tmp_path / "eval"
    assert cli.main(["eval", str(run / "best"), "--controllers", "none", "--jitter", "1",
                     "--seeds", "1", "--workers", "1", "--out", str(out), "--no-progress"]) == 0
    folder = ship_policy.ship(run, out, "mine", best=True)
    assert (folder / "policy.npz").read_bytes() == (run / "best" / "policy.npz").read_bytes()
    text = (folder / "POLICY.md").read_text()
    assert "The best policy by validation" in text and "| 1 | policy: mine |" in text
    with pytest.raises(SystemExit, match="holds no rows of policy: tiny "):
        ship_policy.ship(run, out, "other")  # its final policy was not evaluated
    assert not (tmp_path / "policies" / "other").exists()
