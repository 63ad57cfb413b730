"""The policy kinds: each algorithm's hyperparameters per observation kind.

Both observation kinds are Dicts, so both use stable-baselines3's ``MultiInputPolicy``:
an MLP over the concatenated vectors for "features", a CNN (NatureCNN) on the stacked
frames beside an MLP input for the proprioception and goal for "pixels". Values follow
RL Baselines3 Zoo's for continuous control, sized for two CPU cores: small networks (64 x
64 units: fast updates, and a policy that ships in a few hundred KB), short rollouts,
and for SAC a replay buffer that fits in memory with frames.
"""

from __future__ import annotations

import ast
import inspect
from collections.abc import Iterable, Mapping
from typing import Any

from lgmd_sim.extras import require

__all__ = ["HYPERPARAMETERS", "hyperparameters", "make_model", "parse_overrides"]

#: (algo, obs) -> constructor keyword arguments (besides policy, env, seed).
HYPERPARAMETERS: dict[tuple[str, str], dict[str, Any]] = {
    ("ppo", "features"): {
        "n_steps": 1024, "batch_size": 256, "n_epochs": 10, "learning_rate": 3e-4,
        "gamma": 0.99, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0,
        "policy_kwargs": {"net_arch": [64, 64]},
    },
    ("ppo", "pixels"): {
        "n_steps": 256, "batch_size": 128, "n_epochs": 4, "learning_rate": 2.5e-4,
        "gamma": 0.99, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0,
    },
    ("sac", "features"): {
        "buffer_size": 200_000, "learning_starts": 2_000, "batch_size": 256,
        "train_freq": 1, "gradient_steps": 1, "learning_rate": 3e-4, "gamma": 0.99,
        "tau": 0.005, "ent_coef": "auto_0.1", "policy_kwargs": {"net_arch": [64, 64]},
    },
    ("sac", "pixels"): {
        # 4 x 60 x 80 frames: 10,000 transitions (observation and next) take about 400 MB
        "buffer_size": 10_000, "learning_starts": 1_000, "batch_size": 64,
        "train_freq": 1, "gradient_steps": 1, "learning_rate": 3e-4, "gamma": 0.99,
        "tau": 0.005, "ent_coef": "auto_0.1",
    },
}


def parse_overrides(items: Iterable[str], algo: str) -> dict[str, Any]:
    """``KEY=VALUE`` overrides of `algo`'s constructor arguments, each value a Python
    literal (``n_steps=64``, ``policy_kwargs={'net_arch': [32, 32]}``).

    Raises:
        ValueError: not KEY=VALUE, not a literal, or a key the algorithm does not take.
    """
    from lgmd_sim.policies.folder import ALGOS

    cls = getattr(require("stable_baselines3", "rl"), ALGOS[algo])
    valid = set(inspect.signature(cls.__init__).parameters) - {"self", "policy", "env", "seed"}
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep:
            raise ValueError(f"hyperparameter {item!r} is not KEY=VALUE")
        if key not in valid:
            raise ValueError(f"unknown hyperparameter {key!r} for {algo}")
        try:
            out[key] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            out[key] = text  # a plain word: a string ("auto")
    return out


def hyperparameters(algo: str, obs: str, overrides: Mapping[str, Any] | None = None
                    ) -> dict[str, Any]:
    """The constructor arguments of (algo, obs) with `overrides` on top."""
    return {**HYPERPARAMETERS[(algo, obs)], **(overrides or {})}


def make_model(algo: str, venv: Any, kwargs: Mapping[str, Any], seed: int) -> Any:
    """A new stable-baselines3 model of `algo` on `venv` (on the CPU)."""
    from lgmd_sim.policies.folder import ALGOS

    cls = getattr(require("stable_baselines3", "rl"), ALGOS[algo])
    return cls("MultiInputPolicy", venv, seed=seed, device="cpu", verbose=0, **kwargs)
