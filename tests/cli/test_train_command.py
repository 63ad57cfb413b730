"""`lgmd-sim train` end to end at tiny sizes: a run's files, the S-layer grid, reward
shaping, resuming, validation as eval plays it, eval beside the hand-made controllers,
bad input and bad config files in one line, a privileged policy, the policy's release."""

from __future__ import annotations

import csv
import itertools
import json
import shutil
import sys

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import cli, controllers
from lgmd_sim.policies.observe import base_env, observe
from lgmd_sim.training.envs import make_vec_env

from train_tiny import config_option

# The tripod scenario at 64 x 64: episodes of a few seconds, steps of a few ms.
ENV = "lgmd_sim/StationaryApproach-v0"
TINY = ["train", "--algo", "ppo", "--env", ENV, "--resolution", "small", "--hp", "n_steps=64",
        "--hp", "batch_size=64", "--no-progress"]


#: the keys of TINY's --config file
TINY_KEYS = {"eval_every": 128, "eval_seeds": 2, "checkpoint_every": 128}


def _nan_reward_env(**overrides):
    class NanReward(gym.Wrapper):
        def step(self, action):
            obs, _, terminated, truncated, info = self.env.step(action)
            return obs, float("nan"), terminated, truncated, info

    from lgmd_sim.envs import JitterEnv

    return NanReward(JitterEnv("StationaryApproach", **overrides))


def test_a_privileged_policy_trains_and_acts_on_a_rendering_env(tmp_path):
    pytest.importorskip("stable_baselines3")
    from lgmd_sim.policies.folder import load_config
    from lgmd_sim.policies.observe import base_env
    from lgmd_sim.training.envs import make_vec_env

    out = tmp_path / "privileged"
    env_id = "lgmd_sim/StationaryApproach-v0"  # episodes of a few seconds
    keys = tmp_path / "tiny.toml"
    keys.write_text("eval_every = 128\neval_seeds = 1\ncheckpoint_every = 128\n")
    assert cli.main(["train", "--obs", "privileged", "--env", env_id, "--resolution", "small",
                     "--steps", "128", "--envs", "1", "--hp", "n_steps=64", "--hp",
                     "batch_size=64", "--config", str(keys), "--no-progress",
                     "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["config"]["obs"] == "privileged" and record["config"]["model"] is None
    config = load_config(out)[1]
    assert config.obs == "privileged" and config.model is None

    # the training VecEnv observes as the controller does, bit for bit, without frames
    envs = make_vec_env(config, 1)
    envs.venv.seed(3)
    batched = envs.venv.reset()
    single = observe(base_env(config), config)
    assert single.unwrapped.params.frame == "none"
    obs, _ = single.reset(seed=3)
    assert set(obs) == set(batched) == {"proprio", "threat"}
    for key in obs:
        np.testing.assert_array_equal(obs[key], batched[key][0])
    envs.close()
    single.close()

    # on a rendering environment (the benchmark's), as on the frameless one it trained in;
    # at another frame size too, as it reads no frames (the smallest: the cheapest)
    policy = controllers.make("policy", path=str(out))
    acted = {}
    for name, env in (("rendering", gym.make(env_id, resolution=[16, 16], jitter=1.0)),
                      ("frameless", base_env(config))):
        env = policy.wrap_env(env)
        acted[name] = [s.action.tolist() for s in controllers.rollout(env, policy, seed=1000)
                       if s.action is not None]
        env.close()
    assert len(acted["rendering"]) > 10 and acted["rendering"] == acted["frameless"]
    assert np.isfinite(acted["rendering"]).all()


def _train(out, *extra: str, **keys) -> int:
    """TINY into `out`, with a --config file beside it holding TINY_KEYS and `keys`."""
    config = config_option(out.parent / f"{out.name}.toml", {**TINY_KEYS, **keys})
    return cli.main([*TINY, *config, "--out", str(out), *extra])


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


def test_the_s_layer_grid_its_history_and_memory_are_options_the_policy_keeps(tmp_path):
    out = tmp_path / "grid"
    assert _train(out, "--steps", "64", "--envs", "1", grid=[2, 4], grid_history=3,
                  memory=30) == 0
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


def test_reward_shaping_reaches_the_training_environments_only(tmp_path, monkeypatch, capsys):
    from lgmd_sim.training import envs as training_envs

    built = []

    def recording(config, n_envs, overrides=None):
        vec = make_vec_env(config, n_envs, overrides)
        built.append({k: getattr(vec.base.get_attr("params")[0], k)
                      for k in ("goal_bonus", "time_penalty", "collision_penalty")})
        return vec

    monkeypatch.setattr(training_envs, "make_vec_env", recording)
    out = tmp_path / "shaped"
    assert _train(out, "--steps", "64", "--envs", "1",
                  reward=["goal_bonus=5", "time_penalty=0.5"]) == 0
    shaped, validation = built
    assert shaped == {"goal_bonus": 5.0, "time_penalty": 0.5, "collision_penalty": 10.0}
    assert validation == {"goal_bonus": 0.0, "time_penalty": 0.0, "collision_penalty": 10.0}
    record = json.loads((out / "run.json").read_text())
    assert record["config"]["reward"] == ["goal_bonus=5", "time_penalty=0.5"]
    assert "training reward goal_bonus=5, time_penalty=0.5" in (out / "summary.md").read_text()
    # a key a resume may not change, from a --config file, is refused naming the file
    changed = tmp_path / "changed.toml"
    changed.write_text('reward = ["goal_bonus=1"]\nvalue_warmup = 0\n')
    capsys.readouterr()
    assert cli.main(["train", "--resume", str(out), "--steps", "128",
                     "--config", str(changed)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(
        f"lgmd-sim train: error: {changed}: reward = [\"goal_bonus=1\"] differs from the run "
        "being resumed (['goal_bonus=5', 'time_penalty=0.5']); only --steps, --envs, --hp and "
        "the key value_warmup may change"), err
    assert json.loads((out / "run.json").read_text())["sessions"][-1]["steps"][1] == 64


@pytest.mark.slow
def test_resume_continues_the_step_count(run, tmp_path):
    out = tmp_path / "resumed"
    shutil.copytree(run, out)
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
    alone (`bench closed-loop --policies`): the same distance travelled, to the last digit
    (a batch of observations rounds the CNN's actions differently, and the robot drives on them; a
    vector policy's actions come from `lgmd_sim.policies.forward` on both sides)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from lgmd_sim.training.callbacks import run_episodes
    from lgmd_sim.training.envs import normalized_keys

    out = tmp_path / obs
    assert _train(out, "--obs", obs, "--env", "lgmd_sim/RoughTerrainObstacles-v0",
                  "--steps", "64", "--envs", "1", eval_seeds=1) == 0
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


@pytest.mark.slow
def test_policies_run_beside_the_hand_made_controllers(run, tmp_path, capsys):
    out = tmp_path / "eval"
    assert cli.main(["bench", "closed-loop", "--policies", f"{run},{run / 'best'}",
                     "--controllers", "straight,reactive", "--models", "lgmd1", "--jitter", "1",
                     "--seeds", "1", "--workers", "1", "--out", str(out), "--no-progress"]) == 0
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert {(r["controller"], r["tag"] or r["model"]) for r in rows} == {
        ("policy", "tiny"), ("policy", "tiny-best"), ("straight", ""), ("reactive", "lgmd1")}
    assert {r["seed"] for r in rows} == {"1000"}
    table = (out / "eval.md").read_text()
    assert "| 1 | policy: tiny |" in table and "reactive: lgmd1/published (best detector)" in table
    assert json.loads((out / "run.json").read_text())["config"]["resolution"] == "small"
    for name in ("summary.md", "collisions_vs_jitter.png", "trajectories.png"):
        assert (out / name).is_file()


@pytest.mark.parametrize(("args", "keys", "message"), [
    (["--algo", "a2c"], {}, "--algo must be one of 'ppo', 'sac', got 'a2c'"),
    (["--obs", "rgb"], {}, "--obs must be one of 'features', 'pixels', 'privileged', got 'rgb'"),
    (["--model", "lgmd9"], {}, "unknown model 'lgmd9'"),
    (["--preset", "nope"], {}, "unknown preset 'nope'"),
    (["--env", "lgmd_sim/Moon-v0"], {}, "unknown environment id 'lgmd_sim/Moon-v0'"),
    (["--steps", "0"], {}, "--steps must be an integer >= 1, got 0"),
    (["--hp", "warp=9"], {}, "unknown hyperparameter 'warp'"),
    ([], {"reward": ["jitter=2"]}, "never.toml: reward 'jitter=2': not KEY=VALUE with KEY one of"),
    ([], {"reward": ["goal_bonus=lots"]}, "never.toml: reward goal_bonus=lots: 'lots' is not a "
     "number"),
    ([], {"reward": ["goal_bonus=-5"]}, "parameter goal_bonus=-5.0 must be"),
    ([], {"reward": ["goal_bonus=1", "goal_bonus=2"]}, "never.toml: reward goal_bonus is given "
     "twice"),
    (["--env", "lgmd_test/NanReward-v0", "--envs", "1"], {}, "is not finite"),
    (["--obs", "pixels"], {"grid": [2, 2]}, "never.toml: grid is of obs features, not "
     "pixels"),
    (["--obs", "privileged"], {"grid_history": 2}, "never.toml: grid_history is of obs "
     "features"),
    ([], {"grid_history": 0}, "never.toml: grid_history must be an integer >= 1, got 0"),
    ([], {"memory": -1}, "never.toml: memory must be an integer >= 0, got -1"),
    (["--obs", "pixels"], {"memory": 30}, "never.toml: memory is of obs features"),
])
def test_bad_input_is_one_line_before_training(tmp_path, capsys, args, keys, message):
    if "lgmd_test/NanReward-v0" not in gym.registry:
        gym.register("lgmd_test/NanReward-v0", entry_point=_nan_reward_env)
    out = tmp_path / "never"
    assert _train(out, "--steps", "64", *args, **keys) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()


@pytest.mark.parametrize(("text", "message"), [
    ("dagger_round = 3\n", "unknown key 'dagger_round' (did you mean dagger_rounds?)"),
    ("dagger_rounds = 0\n", "dagger_rounds must be an integer >= 1, got 0"),
    ("eval_seeds = 200\n", "eval_seeds must be at most 100"),
    ('dagger_student = "greedy"\n', "dagger_student must be one of 'sample', 'mean', got 'greedy'"),
    ('grid = "3x5"\n', "grid must be a sequence of 2 values ([rows, columns]), got '3x5'"),
    ('reward = "goal_bonus=5"\n', "reward must be a sequence of values (KEY=VALUE strings)"),
    ('[teacher]\nname = "oracle"\n', "teacher must be oracle, steer, reactive or a policy"),
    ('teacher = "nowhere"\n', "teacher nowhere: no policy at nowhere"),
    ("steps = true\n", "steps must be an integer >= 1, got True"),
    ("teacher =\n", "not a TOML file (Invalid value (at line 1, column 10))"),
    (None, "cannot read it"),
])
def test_a_bad_config_file_is_one_line_naming_the_file_and_the_key(tmp_path, capsys, text,
                                                                    message):
    path = tmp_path / "bad.toml"
    if text is not None:
        path.write_text(text)
    out = tmp_path / "never"
    assert cli.main(["train", "--config", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"lgmd-sim train: error: {path}: ") and message in err, err
    assert not out.exists()


def test_an_option_s_error_is_not_the_config_file_s(tmp_path, capsys):
    path = tmp_path / "good.toml"
    path.write_text('teacher = "oracle"\nsteps = 1000\n')  # --steps overrides it
    assert cli.main(["train", "--config", str(path), "--steps", "0",
                     "--out", str(tmp_path / "never")]) == 2
    assert capsys.readouterr().err.strip() == (
        "lgmd-sim train: error: --steps must be an integer >= 1, got 0")


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
                 ["bench", "closed-loop", "--policies", "shipped", "--out",
                  str(tmp_path / "y")]):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "'rl' extra" in err


def test_ship_policy_releases_a_runs_best_policy_with_its_rows(run, tmp_path, monkeypatch):
    import importlib
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[2] / "docs/experiments/tools"))
    ship_policy = importlib.import_module("ship_policy")
    monkeypatch.setattr(ship_policy, "POLICIES", tmp_path / "policies")
    out = tmp_path / "eval"
    assert cli.main(["bench", "closed-loop", "--policies", str(run / "best"), "--controllers",
                     "none", "--jitter", "1", "--seeds", "1", "--workers", "1", "--out",
                     str(out), "--no-progress"]) == 0
    folder = ship_policy.ship(run, out, "mine", best=True)
    assert (folder / "policy.npz").read_bytes() == (run / "best" / "policy.npz").read_bytes()
    text = (folder / "POLICY.md").read_text()
    assert "The best policy by validation" in text and "| 1 | policy: mine |" in text
    # how to train it again: the run's keys that are not the defaults, as a --config file
    recipe = ("```toml\nenv = \"lgmd_sim/StationaryApproach-v0\"\npreset = \"paper\"\n"
              "resolution = \"small\"\n"
              "steps = 256\neval_every = 128\neval_seeds = 2\ncheckpoint_every = 128\n"
              "hp = [\"n_steps=64\", \"batch_size=64\"]\n```\n\n```bash\n"
              "lgmd-sim train --config mine.toml --out runs/train/mine\n```")
    assert recipe in text, text
    with pytest.raises(SystemExit, match="holds no rows of policy: tiny "):
        ship_policy.ship(run, out, "other")  # its final policy was not evaluated
    assert not (tmp_path / "policies" / "other").exists()
