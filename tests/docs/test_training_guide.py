"""docs/guides/training.md holds together: its table of the shipped policy is its run
folder's, and its RL Baselines3 Zoo hyperparameters build the environment they name."""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import gymnasium as gym
import pytest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "guides" / "training.md"
EVAL_SHIPPED = ROOT / "docs" / "training" / "runs" / "eval-shipped"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", GUIDE.read_text(), re.S | re.M)


def test_the_shipped_policy_s_table_is_its_evaluation_s_with_its_command():
    text = GUIDE.read_text()
    table = (EVAL_SHIPPED / "eval.md").read_text().strip()
    assert f"\n{table}\n" in text, ("the guide's table differs from "
                                    "docs/training/runs/eval-shipped/eval.md: copy it again")
    command = json.loads((EVAL_SHIPPED / "run.json").read_text())["command"]
    # recorded by `lgmd-sim eval` with no policy: today's `bench closed-loop --policies shipped`
    command = command.replace("lgmd-sim eval ", "lgmd-sim bench closed-loop --policies shipped ")
    assert f"```bash\n{command}\n```\n\n{table}" in text


def test_the_zoo_hyperparameters_build_their_environment_for_multi_input_policy():
    """As rl_zoo3 reads the file: the environment id's entry, its env_kwargs, each
    env_wrapper a "module.Class" with keyword arguments, the policy by name."""
    yaml = pytest.importorskip("yaml")
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    import lgmd_sim  # noqa: F401  (registers the scenarios, as --gym-packages lgmd_sim does)

    (block,) = _blocks("yaml")
    (env_id, hp), = yaml.safe_load(block).items()
    assert hp["policy"] == "MultiInputPolicy"
    env = gym.make(env_id, **hp["env_kwargs"])
    for wrapper in hp["env_wrapper"]:
        (spec, kwargs), = wrapper.items()
        module, name = spec.rsplit(".", 1)
        env = getattr(importlib.import_module(module), name)(env, **kwargs)
    spaces = env.observation_space.spaces
    assert "frame" not in spaces and {"proprio", "goal", "lgmd_grid"} <= set(spaces)
    assert all(len(s.shape) == 1 for s in spaces.values())  # vectors: an MLP reads them
    assert spaces["lgmd_grid"].shape == (3 * 5,)
    model = PPO(hp["policy"], env, n_steps=hp["n_steps"], batch_size=hp["batch_size"],
                n_epochs=hp["n_epochs"], learning_rate=hp["learning_rate"],
                policy_kwargs=hp["policy_kwargs"], device="cpu")
    obs, _ = env.reset(seed=0)
    action, _ = model.predict(obs, deterministic=True)
    assert env.action_space.contains(action.astype(env.action_space.dtype))
    env.close()


KEYS = re.compile(r"^<!-- TrainConfig keys: .*?-->\n(.*?)^<!-- end of TrainConfig keys -->",
                  re.S | re.M)


def test_the_guide_lists_every_config_key_as_train_config_declares_it():
    """The keys of `lgmd-sim train --config`, their defaults and meanings, are TrainConfig's
    fields' (declared there once)."""
    from lgmd_sim.core.configfile import keys_markdown
    from lgmd_sim.training.config import TrainConfig

    found = KEYS.search(GUIDE.read_text())
    assert found, "the guide lost its list of the config file's keys"
    assert found.group(1) == keys_markdown(TrainConfig), (
        "the guide's keys differ from TrainConfig's: `python -m scripts.reference` writes them")


SHIPPED_RUN = ROOT / "docs" / "training" / "runs" / "student-feedback-h4-mean"
#: what the shipped run set that its recipe leaves out: how often it validated and saved
VALIDATION = ("eval_every", "eval_seeds", "checkpoint_every")


def test_the_guide_s_recipe_and_the_shipped_policy_s_train_the_shipped_run_again(tmp_path):
    """POLICY.md's recipe makes the shipped policy (its observations and network), and the
    guide's `train` line with its student.toml makes the same run (validating as by
    default); where the run's folder is here (the machine that made it, not a checkout),
    the recipe is the configuration its run.json recorded."""
    import shlex

    from lgmd_sim.cli import build_parser
    from lgmd_sim.cli.train import config_from_args
    from lgmd_sim.policies import DEFAULT, load_config, path
    from lgmd_sim.training.config import TrainConfig

    def made(command: str, toml: str) -> dict:
        (tmp_path / "student.toml").write_text(toml)
        argv = shlex.split(command)[1:]
        argv[argv.index("--config") + 1] = str(tmp_path / "student.toml")
        return config_from_args(build_parser().parse_args(argv)).as_json()

    policy_md = (path(DEFAULT) / "POLICY.md").read_text()
    (toml,) = re.findall(r"^```toml\n(.*?)^```", policy_md, re.S | re.M)
    (command,) = [c for c in re.findall(r"^```bash\n(.*?)^```", policy_md, re.S | re.M)
                  if "--config" in c]
    recipe = made(command, toml)
    assert TrainConfig(**recipe).policy() == load_config(path(DEFAULT))[1]
    (toml,) = _blocks("toml")
    (line,) = [line for block in _blocks("bash")
               for line in block.replace("\\\n", " ").splitlines()
               if line.startswith("lgmd-sim train ")]
    ours = made(line.split("#")[0], toml)
    assert ({k: v for k, v in ours.items() if k not in VALIDATION}
            == {k: v for k, v in recipe.items() if k not in VALIDATION})
    if (SHIPPED_RUN / "run.json").is_file():
        record = json.loads((SHIPPED_RUN / "run.json").read_text())
        shipped = json.loads((path(DEFAULT) / "policy.json").read_text())
        assert shipped["trained"]["command"] == record["sessions"][0]["command"]  # its run
        assert {k: v for k, v in recipe.items() if k in record["config"]} == record["config"]
