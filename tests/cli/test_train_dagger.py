"""DAgger (`lgmd_sim.training.dagger`, the teacher key of `lgmd-sim train --config`): the
teacher labels the states the student visits (after auto-resets too), beta decides who
drives, cloning fits the labels, and a run's rounds are recorded and resume where they
stopped."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import cli, controllers
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.policies.observe import base_env, observe
from lgmd_sim.training import curve, dagger
from lgmd_sim.training.envs import make_vec_env

from train_tiny import config_option

ENV = "lgmd_sim/RoughTerrainObstacles-v0"
# frameless (privileged) observations: the DAgger machinery at the physics' speed; 1 s
# episodes, so that the workers reset during a collection
CONFIG = PolicyConfig("ppo", "privileged", ENV, "small", 1.0, None, None)
SHORT = {"time_limit": 1.0}
CRUISE = np.array([0.3, 0.0], np.float32)


def _collect(beta, steps=45, seed=5):
    from stable_baselines3.common.vec_env import VecNormalize

    envs = make_vec_env(CONFIG, 2, SHORT)
    try:
        venv = VecNormalize(envs.venv, norm_reward=False)
        venv.seed(seed)
        return dagger.collect(venv, lambda: envs.base.reset_infos,
                              lambda norm: np.tile(CRUISE, (2, 1)),
                              dagger.Teacher("oracle", 2, CONFIG), steps, beta,
                              np.random.default_rng(0))
    finally:
        envs.close()


def _replay(seed, actions):
    """One environment driven by `actions` (auto-resetting as a VecEnv does): its raw
    observations and a fresh Oracle's action on each."""
    env = observe(base_env(CONFIG, **SHORT), CONFIG)
    oracle = controllers.make("oracle")
    obs, info = env.reset(seed=seed)
    seen, labels = [], []
    for action in actions:
        seen.append(obs)
        labels.append(oracle.act(obs, info))
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            obs, info = env.reset()
            oracle.reset()
    env.close()
    return seen, np.array(labels, np.float32)


@pytest.mark.slow
def test_dagger_relabels_with_the_teachers_actions_on_the_students_states():
    obs, labels, executed = _collect(beta=0.0)
    assert np.array_equal(executed, np.tile(CRUISE, (90, 1)))  # the student drove
    for i in range(2):  # rows are step-major: environment i at rows i, i + 2, ...
        seen, expected = _replay(5 + i, executed[i::2])
        for key in ("proprio", "goal", "threat"):
            np.testing.assert_array_equal(obs[key][i::2], np.stack([o[key] for o in seen]))
        np.testing.assert_array_equal(labels[i::2], expected)
    assert np.abs(labels[:, 1]).max() > 0.5  # the Oracle turned away at least once
    # the episodes of 1 s (30 steps) ended and restarted during the 45 steps
    assert obs["goal"][0::2][30, 0] > obs["goal"][0::2][29, 0]


def test_beta_one_drives_with_the_teacher():
    _, labels, executed = _collect(beta=1.0)
    np.testing.assert_array_equal(executed, labels)


def test_beta_falls_from_the_teacher_to_the_student_by_half_the_rounds():
    assert [dagger.beta(k, 10) for k in range(7)] == pytest.approx([1, 0.8, 0.6, 0.4, 0.2, 0, 0])
    assert dagger.beta(0, 1) == 1.0


def test_cloning_fits_the_labels():
    import torch
    from stable_baselines3 import PPO

    envs = make_vec_env(CONFIG, 1, SHORT)
    model = PPO("MultiInputPolicy", envs.venv, n_steps=64, batch_size=64, seed=0)
    envs.close()
    rng = np.random.default_rng(0)
    obs = {k: rng.normal(size=(256, *s.shape)).astype(np.float32)
           for k, s in model.observation_space.spaces.items()}
    actions = np.tanh(obs["threat"][:, :2])  # a function of the observation
    first = dagger.fit(model.policy, obs, actions, epochs=1, batch_size=64,
                       learning_rate=3e-3, seed=0)
    last = dagger.fit(model.policy, obs, actions, epochs=60, batch_size=64,
                      learning_rate=3e-3, seed=0)
    assert last < first - 1.0
    with torch.no_grad():
        mean = model.policy.predict(obs, deterministic=True)[0]
    assert np.abs(mean - actions).mean() < 0.15


TINY = ["train", "--obs", "privileged", "--env", ENV, "--envs", "1", "--hp", "n_steps=64",
        "--hp", "batch_size=64", "--no-progress"]
#: the keys of TINY's --config file
TINY_KEYS = {"eval_every": 10000, "eval_seeds": 1, "checkpoint_every": 10000,
             "teacher": "oracle", "imitation_steps": 128, "dagger_rounds": 4}




def test_the_reactive_teacher_manoeuvres_on_the_students_own_alarm_away_from_its_busier_side():
    features = PolicyConfig("ppo", "features", ENV, "small", 1.0, "lgmd1", None)
    teacher = dagger.Teacher("reactive", 2, features)
    quiet = {"lgmd_alarm": np.zeros(1, np.float32), "lgmd_grid": np.full(3, 1 / 3, np.float32)}
    left = {"lgmd_alarm": np.ones(1, np.float32),
            "lgmd_grid": np.array([0.6, 0.3, 0.1], np.float32)}
    right = {**left, "lgmd_grid": left["lgmd_grid"][::-1].copy()}
    p = teacher.controllers[0].params
    for i in range(2):
        teacher.reset(i)
    # no alarm: towards the goal (bearing 0.1 rad, to the left), as Straight does
    cruise = teacher.act(0, quiet, {"time": 0.0, "goal_bearing": 0.1})
    np.testing.assert_allclose(cruise, [p.cruise, min(1.0, p.heading_gain * 0.1)])
    # an alarm with more of the S layer on the left: brake and turn right, and the
    # manoeuvre lasts its avoid_time whatever the alarm does next
    np.testing.assert_allclose(teacher.act(0, left, {"time": 0.1, "goal_bearing": 0.1}),
                               [p.avoid_speed, -p.avoid_turn])
    np.testing.assert_allclose(teacher.act(0, quiet, {"time": 0.5, "goal_bearing": 0.1}),
                               [p.avoid_speed, -p.avoid_turn])
    np.testing.assert_allclose(teacher.act(1, right, {"time": 0.1, "goal_bearing": 0.1}),
                               [p.avoid_speed, p.avoid_turn])  # each environment its own
    # with a grid history, the newest grid decides (right now, whatever came before)
    teacher.reset(1)
    older_left = {**right, "lgmd_grid": np.concatenate([left["lgmd_grid"], right["lgmd_grid"]])}
    np.testing.assert_allclose(teacher.act(1, older_left, {"time": 0.1, "goal_bearing": 0.1}),
                               [p.avoid_speed, p.avoid_turn])


def test_the_reactive_teacher_needs_the_students_features():
    with pytest.raises(ValueError, match=r"teacher reactive .* needs --obs features"):
        dagger.Teacher("reactive", 1, CONFIG)
    with pytest.raises(ValueError, match="needs 2 columns or more, got 3 x 1"):
        dagger.AlarmAvoid((3, 1))
    two_models = {"lgmd_alarm": np.array([0.0, 1.0], np.float32),
                  "lgmd_grid": np.full(6, 1 / 3, np.float32)}
    with pytest.raises(ValueError, match="one model's features: got 2 alarms and 6 grid"):
        dagger.AlarmAvoid((1, 3)).act(two_models, {"time": 0.0, "goal_bearing": 0.0})


def test_steer_teaches_as_the_controller_acts():
    """Teacher "steer": one `Steer` per environment, labelling as the controller acts."""
    from lgmd_sim.controllers.steer import Steer

    teacher = dagger.Teacher("steer", 2, CONFIG)
    assert [type(c) for c in teacher.controllers] == [Steer, Steer]
    info = {"time": 0.0, "threat_bearing": -0.2, "threat_distance": 0.3, "threat_ttc": 0.4,
            "goal_bearing": 0.1}
    assert np.array_equal(teacher.controllers[0].act({}, info), Steer().act({}, info))


def test_the_value_warmup_trains_the_critic_alone():
    """`critic_only`: PPO's updates inside it change the value function and nothing else,
    and every parameter learns again after it."""
    import torch
    from stable_baselines3 import PPO

    envs = make_vec_env(CONFIG, 1, SHORT)
    try:
        model = PPO("MultiInputPolicy", envs.venv, n_steps=64, batch_size=64, seed=0)
        policy = model.policy
        critic = {id(p) for net in (policy.value_net, policy.mlp_extractor.value_net)
                  for p in net.parameters()}
        before = [p.detach().clone() for p in policy.parameters()]
        with dagger.critic_only(policy):
            model.learn(128)
        for p, old in zip(policy.parameters(), before, strict=True):
            assert torch.equal(p, old) != (id(p) in critic)  # the critic's changed alone
        assert all(p.requires_grad for p in policy.parameters())
    finally:
        envs.close()


@pytest.mark.parametrize("student_actions", dagger.STUDENT_ACTIONS)
def test_the_student_drives_by_its_mean_or_a_sample_and_is_fitted_the_epochs_asked(
        monkeypatch, student_actions):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    envs = make_vec_env(CONFIG, 1, SHORT)
    try:
        venv = VecNormalize(envs.venv, norm_reward=False)
        model = PPO("MultiInputPolicy", venv, n_steps=64, batch_size=64, seed=0)
        predicted, fitted = [], []
        predict = model.predict
        monkeypatch.setattr(model, "predict", lambda obs, deterministic: (
            predicted.append(deterministic) or predict(obs, deterministic=deterministic)))
        monkeypatch.setattr(dagger, "fit", lambda *a, epochs, **k: fitted.append(epochs) or 0.0)
        dagger.imitate(model, venv, lambda: envs.base.reset_infos,
                       dagger.Teacher("oracle", 1, CONFIG), dagger.Labels(), rounds=2,
                       steps=20, first_round=0, seed=0, after_round=lambda *a: None,
                       epochs=7, student_actions=student_actions)
    finally:
        envs.close()
    assert predicted and set(predicted) == {student_actions == "mean"}
    assert fitted == [7, 7]


def test_a_bad_dagger_option_is_one_line_naming_it():
    from lgmd_sim.training.run import TrainConfig

    with pytest.raises(ValueError, match="dagger_student must be one of 'sample', 'mean'"):
        TrainConfig(obs="privileged", model=None, teacher="oracle", dagger_student="greedy")
    with pytest.raises(ValueError, match="dagger_epochs must be an integer >= 1"):
        TrainConfig(obs="privileged", model=None, teacher="oracle", dagger_epochs=0)


def _tiny(folder, **keys) -> list[str]:
    """TINY with its --config file, written into `folder`, holding `keys` too."""
    return [*TINY, *config_option(folder / "tiny.toml", {**TINY_KEYS, **keys})]


@pytest.mark.slow
def test_a_run_with_a_teacher_records_each_round_and_resumes_inside_them(tmp_path):
    out = tmp_path / "student"
    assert cli.main([*_tiny(tmp_path), "--steps", "256", "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    rounds = record["sessions"][0]["imitation"]
    assert [r["round"] for r in rounds] == [0, 1, 2, 3]
    assert [r["beta"] for r in rounds] == [1.0, 0.5, 0.0, 0.0]
    assert [r["labels"] for r in rounds] == [32, 64, 96, 128]
    assert [r["steps"] for r in rounds] == [32, 64, 96, 128]  # on the run's step count
    assert record["sessions"][0]["steps"] == [0, 256]  # the rest by RL
    assert json.loads((out / "checkpoints" / "state.json").read_text())["imitation_round"] == 4
    assert "DAgger from oracle" in (out / "summary.md").read_text()
    assert curve.phase_changes(out) == [(128, "DAgger ends")]  # the learning curve's line
    assert record["sessions"][0]["throughput"]["training_steps_per_s"] > 0  # RL's alone

    # the run, a privileged policy, teaches a student on LGMD features: it sees the
    # student's proprioception and goal and the ground truth, not the student's features
    features = PolicyConfig("ppo", "features", ENV, "small", 1.0, "feedback", None)
    teacher = dagger.Teacher(str(out), 1, features)
    student_env = observe(base_env(features), features)
    privileged_env = observe(base_env(CONFIG), CONFIG)
    obs, info = student_env.reset(seed=3)
    truth, truth_info = privileged_env.reset(seed=3)
    assert "lgmd_potential" in obs
    expected = controllers.make("policy", path=str(out)).act(truth, truth_info)
    np.testing.assert_array_equal(teacher.act(0, obs, info), expected)
    student_env.close()
    privileged_env.close()


@pytest.mark.slow
def test_a_run_stopped_inside_the_rounds_resumes_at_the_next(tmp_path, monkeypatch):
    fit, fitted = dagger.fit, []

    def fails_in_round_2(*args, **kwargs):
        if len(fitted) == 2:
            raise RuntimeError("killed")
        fitted.append(1)
        return fit(*args, **kwargs)

    monkeypatch.setattr(dagger, "fit", fails_in_round_2)
    out = tmp_path / "stopped"
    with pytest.raises(RuntimeError, match="killed"):
        cli.main([*_tiny(tmp_path), "--steps", "256", "--out", str(out)])
    state = json.loads((out / "checkpoints" / "state.json").read_text())
    assert state == {"num_timesteps": 64, "imitation_round": 2, "labels": 64, "critic_until": 0}
    before = dagger.Labels.load(out / "checkpoints" / "dagger.npz")
    assert len(before) == 64

    # saved frozen between rounds, the normalisation learns again once loaded for RL
    from lgmd_sim.training.run import _load_checkpoint

    envs = make_vec_env(CONFIG, 1)
    assert _load_checkpoint(out / "checkpoints", envs.venv, "ppo", {})[0].training
    envs.close()

    monkeypatch.setattr(dagger, "fit", fit)
    assert cli.main(["train", "--resume", str(out), "--no-progress"]) == 0
    record = json.loads((out / "run.json").read_text())
    assert [[r["round"] for r in s.get("imitation", [])] for s in record["sessions"]] == [
        [0, 1], [2, 3]]
    after = dagger.Labels.load(out / "checkpoints" / "dagger.npz")
    assert len(after) == 128  # rounds 0 and 1's, kept, and rounds 2 and 3's
    np.testing.assert_array_equal(after.actions[:64], before.actions)
    assert record["sessions"][1]["steps"] == [64, 256]


@pytest.mark.parametrize(("args", "keys", "message"), [
    (["--algo", "sac"], {}, "teacher needs algo ppo"),
    ([], {"imitation_steps": 256}, "tiny.toml: imitation_steps 256 must be fewer than --steps "
     "256"),
    ([], {"teacher": "nowhere"}, "tiny.toml: teacher nowhere: no policy at nowhere"),
    ([], {"teacher": "reactive"}, "tiny.toml: teacher reactive acts on the student's LGMD "
     "alarm: it needs --obs features, not privileged"),
    ([], {"dagger_rounds": 200}, "tiny.toml: imitation_steps 128 must be at least"),
    ([], {"value_warmup": 128}, "tiny.toml: imitation_steps 128 and value_warmup 128 must be "
     "fewer than --steps 256"),
    ([], {"value_warmup": -1}, "tiny.toml: value_warmup must be an integer >= 0, got -1"),
    ([], {"dagger_student": "greedy"}, "tiny.toml: dagger_student must be one of 'sample', 'mean'"),
])
def test_a_bad_teacher_is_one_line_before_training(tmp_path, capsys, args, keys, message):
    out = tmp_path / "never"
    assert cli.main([*_tiny(tmp_path, **keys), "--steps", "256", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not out.exists()


@pytest.mark.slow
def test_a_student_resumed_past_its_rounds_warms_its_value_function_up_once(tmp_path, capsys):
    """A run that had no warm-up, resumed with a value_warmup key and a new hyperparameter:
    the warm-up starts where it resumes, is recorded, and a later resume does not redo it;
    the hyperparameter is added to the run's, the network's shape cannot change."""
    out = tmp_path / "student"
    assert cli.main([*_tiny(tmp_path), "--steps", "192", "--out", str(out)]) == 0
    keys = tmp_path / "warmup.toml"
    keys.write_text("value_warmup = 128\n")
    assert cli.main(["train", "--resume", str(out), "--steps", "384", "--config", str(keys),
                     "--hp", "target_kl=0.02", "--no-progress"]) == 0
    record = json.loads((out / "run.json").read_text())
    warmup = record["sessions"][1]["value_warmup"]
    assert warmup["steps"] == [192, 320]  # 2 rollouts of 64
    assert warmup["n_updates"][1] - warmup["n_updates"][0] == 20  # 10 epochs each
    assert record["config"]["hp"] == ["n_steps=64", "batch_size=64", "target_kl=0.02"]
    assert record["hyperparameters"]["target_kl"] == 0.02
    state = json.loads((out / "checkpoints" / "state.json").read_text())
    assert state["critic_until"] == 320
    updates = [line.split(" | ") for line in (out / "summary.md").read_text().splitlines()
               if "| value warm-up |" in line or "| PPO |" in line]
    assert [(row[0], row[1]) for row in updates] == [("| 0", "PPO"), ("| 1", "value warm-up"),
                                                     ("| 1", "PPO")]
    assert abs(float(updates[1][4])) < 1e-6  # approximate KL: the policy did not move
    assert curve.phase_changes(out) == [(128, "DAgger ends"), (320, "value warm-up ends")]
    keys.write_text("value_warmup = 64\n")
    assert cli.main(["train", "--resume", str(out), "--steps", "448", "--config", str(keys),
                     "--no-progress"]) == 0
    assert "value_warmup" not in json.loads((out / "run.json").read_text())["sessions"][2]
    capsys.readouterr()
    assert cli.main(["train", "--resume", str(out), "--steps", "512",
                     "--hp", "policy_kwargs={'net_arch': [8]}"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "keeps its network (policy_kwargs)" in err
