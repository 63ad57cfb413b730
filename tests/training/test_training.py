"""`lgmd-sim train` and `lgmd-sim bench closed-loop --policies`: a tiny run end to end, the
saved policy acting as in training (same observations, frozen normalisation,
deterministic), resuming, the shipped policy, and bad input refused in one line before
anything starts."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import controllers, policies
from lgmd_sim.policies import folder as policy_lib
from lgmd_sim.policies.observe import PixelObservation, base_env, observe
from lgmd_sim.training.envs import make_vec_env

# The tripod scenario at 64 x 64: episodes of a few seconds, steps of a few ms; the
# machinery is the robot's.
ENV = "lgmd_sim/StationaryApproach-v0"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A tiny PPO run on the LGMD's features, 256 steps, through the API (the command's own
    run: tests/cli/test_train_command.py)."""
    from lgmd_sim.training.config import TrainConfig
    from lgmd_sim.training.run import train

    out = tmp_path_factory.mktemp("train") / "tiny"
    train(TrainConfig(env=ENV, resolution="small", hp=("n_steps=64", "batch_size=64"),
                      steps=256, eval_every=128, eval_seeds=2, checkpoint_every=128),
          out, progress=False)
    return out


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


def test_policies_by_default_run_reactive_with_the_detector_they_observe_and_draw_seeds(
        run):
    from lgmd_sim.cli import build_parser
    from lgmd_sim.cli.bench import closed_loop_config

    def config_from_args(argv: list[str]):
        return closed_loop_config(build_parser().parse_args(
            ["bench", "closed-loop", "--policies", *argv]))

    _, trained, _ = policy_lib.load_config(run)
    config = config_from_args([str(run)])
    assert config.detectors is None and config.seeds == policies.EVAL_SEEDS
    assert config.bench().detectors == ((trained.model, trained.preset),)
    assert config.bench().top_views == policies.EVAL_TOP_VIEWS > 1  # beside the Oracle
    given = config_from_args([str(run), "--models", "lgmd2"])
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




def _config(*args: str):
    """The TrainConfig of `lgmd-sim train ARGS`."""
    from lgmd_sim.cli import build_parser
    from lgmd_sim.cli.train import config_from_args

    return config_from_args(build_parser().parse_args(["train", *args]))


def test_a_config_file_s_keys_reach_the_train_config_and_the_options_override_them(tmp_path):
    from lgmd_sim.training.config import TrainConfig

    path = tmp_path / "student.toml"
    path.write_text('model = "lgmd1"\npreset = "robot-image"\ngrid = [3, 5]\ngrid_history = 4\n'
                    'teacher = "steer"\ndagger_rounds = 5\ndagger_epochs = 10\n'
                    'dagger_student = "mean"\nreward = ["goal_bonus=10", "effort_penalty=0.001"]\n'
                    'steps = 200000\neval_seeds = 20\nhp = ["n_steps=512"]\n')
    config = _config("--config", str(path))
    assert (config.model, config.preset, config.grid, config.grid_history) == (
        "lgmd1", "robot-image", (3, 5), 4)
    assert (config.teacher, config.dagger_rounds, config.dagger_epochs,
            config.dagger_student) == ("steer", 5, 10, "mean")
    assert config.reward == ("goal_bonus=10", "effort_penalty=0.001")
    assert (config.steps, config.eval_seeds, config.hp) == (200000, 20, ("n_steps=512",))
    assert config.imitation_steps == TrainConfig.imitation_steps  # not in the file: default
    given = _config("--config", str(path), "--model", "feedback", "--steps", "150000",
                    "--hp", "n_steps=256")
    assert (given.model, given.preset, given.steps, given.hp) == (
        "feedback", "robot-image", 150000, ("n_steps=256",))
    assert given.teacher == "steer" and given.grid == (3, 5)
