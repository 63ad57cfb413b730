"""`python -m scripts.speed train`: training steps per second against the bare VecEnv.

Training spends time outside the environments: the LGMD models of "features" run in the
main process on the workers' frames, and the algorithm computes its updates while the
workers wait. Per row, in one run on the same environments:

- the bare VecEnv: the training workers alone, driving straight (what
  `lgmd_sim.training.run` records as each session's ``bare_vec_env_steps_per_s``);
- training: stable-baselines3's ``learn()`` over ``--steps`` environment steps with the
  run's hyperparameters (`lgmd_sim.training.algos`), observation normalisation included,
  no validation or checkpoints;
- their ratio (target: 0.7 or more for PPO on 2 environments).

The rows: PPO on features and on privileged (frameless) observations, and SAC on features
at its default update rate (one gradient step per vector step) and at fewer, larger
updates. PPO's rollouts are shortened to two per run where ``--steps`` is too few for
its own; SAC's updates start at once (no ``learning_starts``), so every timed step pays
for them.
"""

from __future__ import annotations

import os
import time
from typing import Any

from lgmd_sim.core.machine import cpu_name
from scripts.speed import format_table, met

#: (algo, obs, hyperparameter overrides) of each row.
ROWS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("ppo", "features", {}),
    ("ppo", "privileged", {}),
    ("sac", "features", {}),
    ("sac", "features", {"train_freq": 8, "gradient_steps": 8}),
    ("sac", "features", {"train_freq": 8, "gradient_steps": 4}),
)
#: The issue's target for PPO on 2 environments: training at 0.7 of the bare VecEnv.
TARGET = 0.7


def _kwargs(algo: str, obs: str, overrides: dict[str, Any], steps: int, envs: int
            ) -> dict[str, Any]:
    from lgmd_sim.training import algos

    kwargs = algos.hyperparameters(algo, obs, overrides)
    if algo == "ppo":  # at least two rollouts timed
        kwargs["n_steps"] = min(kwargs["n_steps"], max(8, steps // (2 * envs)))
        kwargs["batch_size"] = min(kwargs["batch_size"], kwargs["n_steps"] * envs)
    else:
        kwargs["learning_starts"] = 0
    return kwargs


def measure_row(algo: str, obs: str, overrides: dict[str, Any], *, env: str,
                resolution: str | tuple[int, int], steps: int, envs: int) -> dict[str, Any]:
    """One row: the bare VecEnv's and training's steps per second, and their ratio."""
    import torch

    from lgmd_sim.training import algos
    from lgmd_sim.training.envs import bare_speed, make_vec_env, normalized
    from lgmd_sim.training.run import TrainConfig

    torch.set_num_threads(1)  # as a training run: the workers have the other cores
    config = TrainConfig(algo=algo, env=env, obs=obs, resolution=resolution, envs=envs)
    policy = config.policy()
    kwargs = _kwargs(algo, obs, overrides, steps, envs)
    vec = make_vec_env(policy, envs)
    try:
        bare = bare_speed(vec, policy.env_id)
        venv = normalized(vec.venv, obs, algo, kwargs)
        model = algos.make_model(algo, venv, kwargs, seed=0)
        start = time.perf_counter()
        model.learn(total_timesteps=steps)
        training = model.num_timesteps / (time.perf_counter() - start)
    finally:
        vec.close()
    shown = {k: kwargs[k] for k in ("n_steps", "train_freq", "gradient_steps") if k in kwargs}
    return {"row": f"{algo}/{obs}", "settings": ", ".join(f"{k}={v}" for k, v in shown.items()),
            "envs": envs, "bare": bare, "training": training, "ratio": training / bare}


def run(*, steps: int = 8192, envs: int = 2, env: str = "lgmd_sim/RoughTerrainObstacles-v0",
        resolution: str | tuple[int, int] = "rl", markdown: bool = False) -> int:
    """Measure and print the training speed table (Markdown with `markdown`)."""
    from lgmd_sim.core.extras import require

    require("stable_baselines3", "rl")
    rows = [measure_row(algo, obs, overrides, env=env, resolution=resolution, steps=steps,
                        envs=envs) for algo, obs, overrides in ROWS]
    print(f"# python -m scripts.speed train: {env}, {steps} steps per row on {envs} environments; "
          f"CPU: {cpu_name()}, {os.cpu_count()} cores")
    print(format_table(
        ["algorithm/observation", "settings", "bare VecEnv steps/s", "training steps/s",
         "training / bare", f"target {TARGET} (PPO, 2 environments)"],
        [[r["row"], r["settings"], f"{r['bare']:.0f}", f"{r['training']:.0f}",
          f"{r['ratio']:.2f}",
          met(r["ratio"] >= TARGET)
          if r["row"].startswith("ppo") and envs == 2 else "-"]
         for r in rows],
        markdown,
    ))
    return 0
