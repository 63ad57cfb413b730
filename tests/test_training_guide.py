"""docs/guides/training.md holds together: its table of the shipped policy is its run
folder's, and its RL Baselines3 Zoo hyperparameters build the environment they name."""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import gymnasium as gym
import pytest

ROOT = Path(__file__).resolve().parents[1]
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
