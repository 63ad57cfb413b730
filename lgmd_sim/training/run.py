"""`lgmd-sim train`: one training run in a folder, from its options to its policy.

The run, in order: check every option (a bad one is one line, before anything starts);
build the environments and measure the bare VecEnv's steps per second, which also checks
that rewards are finite; then train with stable-baselines3, validating on fixed held-out
seeds and writing checkpoints as it goes; at the end write the policy folders, the
learning curve and the run's record.

Layout of ``DIR``:

- ``run.json``: the configuration, and per session (the first run and each resume) the
  exact command, versions, machine, environment seeds, steps and throughput;
- ``policy.zip``, ``policy.json``: the final policy (a policy folder, see
  `lgmd_sim.training.policy`); ``best/``: the one with the best validation score;
- ``checkpoints/``: what ``--resume DIR`` continues from;
- ``logs/session-N/``: stable-baselines3's CSV log (``progress.csv``) and TensorBoard
  events; ``learning_curve.png`` is drawn from them; ``summary.md``.

Seeds: the training environments reset with seeds from ``--seed`` (environment i of
session s with ``seed + i + the environments of the sessions before``; later episodes
continue each environment's generator), below `VALIDATION_SEED`; validation uses seeds
``VALIDATION_SEED`` to ``VALIDATION_SEED + eval_seeds - 1``; the benchmark and
``lgmd-sim eval`` use seeds from 1000: the three never share an episode.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import platform
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import __version__
from lgmd_sim.extras import require
from lgmd_sim.fileio import write_text_atomic
from lgmd_sim.training.policy import ALGOS, OBS, PolicyConfig

__all__ = ["DEFAULTS", "VALIDATION_SEED", "train"]

#: The first validation seed; training seeds stay below it, test seeds start at 1000.
VALIDATION_SEED = 900
#: Options of `lgmd-sim train` and their defaults (None in the parsed arguments: not
#: given, so that --resume can tell them from the recorded ones).
DEFAULTS: dict[str, Any] = {
    "algo": "ppo", "env": "lgmd_sim/RoughTerrainObstacles-v0", "obs": "features",
    "model": "feedback", "preset": None, "resolution": "rl", "jitter": 1.0,
    "steps": 300_000, "envs": 2, "seed": 0, "eval_every": 25_000, "eval_seeds": 10,
    "checkpoint_every": 25_000, "hp": [],
}
#: Options a resumed run may change; the others must be as recorded.
_RESUMABLE = ("steps", "envs")
#: Bare VecEnv steps (per environment) timed before training.
_SPEED_STEPS = 100


def _options(args: argparse.Namespace, recorded: Mapping[str, Any] | None) -> dict[str, Any]:
    """The run's options: the recorded ones (resuming) or the defaults, under those given."""
    given = {k: getattr(args, k) for k in DEFAULTS if getattr(args, k, None) is not None}
    if recorded is None:
        return {**DEFAULTS, **given}
    for key, value in given.items():
        if key not in _RESUMABLE and json.loads(json.dumps(value)) != recorded[key]:
            raise ValueError(f"--{key.replace('_', '-')} {value} differs from the run being "
                             f"resumed ({recorded[key]}); only --steps and --envs may change")
    return {**recorded, **given}


def _check(o: dict[str, Any]) -> None:
    """Raise ValueError naming the first bad option."""
    import gymnasium as gym

    from lgmd_sim import models
    from lgmd_sim.world.params import MAX_JITTER

    if o["algo"] not in ALGOS:
        raise ValueError(f"unknown algorithm {o['algo']!r}; available: {', '.join(ALGOS)}")
    if o["obs"] not in OBS:
        raise ValueError(f"unknown observation {o['obs']!r}; available: {', '.join(OBS)}")
    try:
        gym.spec(o["env"])
    except gym.error.Error:
        raise ValueError(f"unknown environment id {o['env']!r} (lgmd-sim envs lists them)"
                         ) from None
    if o["obs"] == "features":
        o["model"], o["preset"] = models.parse_spec(
            o["model"] if o["preset"] is None else f"{o['model']}/{o['preset']}")
    else:
        o["model"] = o["preset"] = None
    for key in ("steps", "envs", "eval_every", "checkpoint_every", "eval_seeds"):
        if not (isinstance(o[key], int) and o[key] >= 1):
            raise ValueError(f"--{key.replace('_', '-')} must be a positive integer, "
                             f"got {o[key]}")
    if o["eval_seeds"] > 1000 - VALIDATION_SEED:
        raise ValueError(f"--eval-seeds must be at most {1000 - VALIDATION_SEED} (validation "
                         f"seeds are {VALIDATION_SEED} to 999), got {o['eval_seeds']}")
    if not (isinstance(o["seed"], int) and 0 <= o["seed"]):
        raise ValueError(f"--seed must be an integer >= 0, got {o['seed']}")
    if not (isinstance(o["jitter"], float | int) and 0 <= o["jitter"] <= MAX_JITTER):
        raise ValueError(f"--jitter must be a number in [0, {MAX_JITTER:g}], got {o['jitter']}")


def _versions() -> dict[str, str]:
    # from the installed metadata: importing mujoco here would fix its GL backend before
    # lgmd_sim.world.gl chooses it
    from importlib.metadata import version

    return {"lgmd-sim": __version__, "python": platform.python_version(),
            **{name: version(name) for name in ("stable-baselines3", "torch", "gymnasium",
                                                "mujoco", "numpy")}}


def _prepare_folder(out: Path) -> None:
    """Refuse a folder that holds anything (another run, or something else)."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"output folder {out} is a file")
    if out.is_dir() and any(out.iterdir()):
        held = ("holds a training run: add --resume " + str(out) + " to continue it"
                if (out / "run.json").is_file() else "is not empty and holds no run")
        raise ValueError(f"output folder {out} {held}, or choose another folder")


def _recorded(folder: Path) -> dict[str, Any]:
    """The record of the run in `folder`, which must hold a checkpoint."""
    try:
        record = json.loads((folder / "run.json").read_text())
        record["options"]
    except (OSError, ValueError, KeyError):
        raise ValueError(f"--resume {folder}: no training run there (no readable run.json)"
                         ) from None
    if not (folder / "checkpoints" / "state.json").is_file():
        raise ValueError(f"--resume {folder}: the run has no checkpoint to resume from")
    return record


def _bare_speed(envs: Any, env_id: str) -> float:
    """Steps per second (over all environments) of the workers' VecEnv alone, driving
    straight at 0.6 m/s; raise ValueError on a reward that is not finite."""
    base = envs.base
    base.reset()
    actions = np.tile(np.array([0.6, 0.0], np.float32), (base.num_envs, 1))
    start = time.perf_counter()
    for step in range(_SPEED_STEPS):
        _, rewards, _, _ = base.step(actions)
        if not np.isfinite(rewards).all():
            raise ValueError(f"{env_id}: reward {rewards.tolist()} at step {step + 1} is not "
                             "finite: check the environment's reward parameters")
    return _SPEED_STEPS * base.num_envs / (time.perf_counter() - start)


def _normalize_keys(obs_space: Any, obs: str) -> list[str]:
    # frames go to the CNN as they are (scaled to [0, 1] by the policy)
    return [k for k in obs_space.spaces if not (obs == "pixels" and k == "frame")]


def train(args: argparse.Namespace) -> int:
    """`lgmd-sim train`."""
    resume = Path(args.resume) if args.resume else None
    if resume is not None and args.out is not None and Path(args.out) != resume:
        raise ValueError("--out and --resume name different folders: --resume continues "
                         "the run in its own folder")
    record = _recorded(resume) if resume else None
    o = _options(args, record["options"] if record else None)
    _check(o)
    from lgmd_sim.training import algos

    require("stable_baselines3", "rl")
    require("tensorboard", "rl")
    kwargs = algos.hyperparameters(o["algo"], o["obs"], algos.parse_overrides(o["hp"], o["algo"]))
    out = resume or Path(args.out or f"train-{o['algo']}-{o['obs']}")
    if resume is None:
        _prepare_folder(out)
    sessions = record["sessions"] if record else []
    if resume is not None and o["steps"] <= _checkpoint_steps(resume / "checkpoints"):
        raise ValueError(f"--steps {o['steps']}: the run is at "
                         f"{_checkpoint_steps(resume / 'checkpoints')} steps already")
    first_seed = o["seed"] + sum(s["env_seeds"][1] for s in sessions)
    if first_seed + o["envs"] > VALIDATION_SEED:
        raise ValueError(f"training seeds {first_seed} to {first_seed + o['envs'] - 1} would "
                         f"reach the validation seeds (from {VALIDATION_SEED}): use a lower "
                         "--seed or fewer --envs")
    config = PolicyConfig(o["algo"], o["obs"], o["env"], o["resolution"], float(o["jitter"]),
                          o["model"], o["preset"])
    return _train(out, o, config, kwargs, sessions, first_seed, args)


def _train(out: Path, o: dict[str, Any], config: PolicyConfig, kwargs: dict[str, Any],
           sessions: list[dict[str, Any]], first_seed: int, args: argparse.Namespace) -> int:
    import torch
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.vec_env import VecNormalize

    from lgmd_sim.bench.runs import machine
    from lgmd_sim.training import algos, callbacks, curve
    from lgmd_sim.training import policy as policies
    from lgmd_sim.training.envs import make_vec_env

    torch.set_num_threads(1)  # the environment workers have the other cores
    checkpoints = out / "checkpoints"
    resuming = bool(sessions)
    envs = make_vec_env(config, o["envs"])
    validation = None
    try:
        bare = _bare_speed(envs, config.env_id)
        keys = _normalize_keys(envs.venv.observation_space, config.obs)
        if resuming:
            venv, model = _load_checkpoint(checkpoints, envs.venv, config.algo)
            model.set_random_seed(o["seed"] + len(sessions))
        else:
            venv = VecNormalize(envs.venv, norm_obs_keys=keys, gamma=kwargs.get("gamma", 0.99),
                                norm_reward=config.algo == "ppo")  # SAC: rewards as they are
            model = algos.make_model(config.algo, venv, kwargs, o["seed"])
        started = time.time()
        session = {"command": args.command_line, "started": time.strftime("%Y-%m-%d %H:%M:%S"),
                   "versions": _versions(), "machine": machine(),
                   "env_seeds": [first_seed, o["envs"]]}
        out.mkdir(parents=True, exist_ok=True)
        options = {**o, "resolution": json.loads(json.dumps(o["resolution"]))}
        _write_record(out, options, config, kwargs, [*sessions, session], "running")
        venv.seed(first_seed)  # environment i: first_seed + i, at the reset learn() makes
        model.set_logger(configure(str(out / "logs" / f"session-{len(sessions)}"),
                                   ["csv", "tensorboard"]))
        steps_from = model.num_timesteps

        validation = make_vec_env(config, o["envs"])
        val_norm = VecNormalize(validation.venv, norm_obs_keys=keys, training=False,
                                norm_reward=False)
        validation.venv = val_norm

        def sync() -> None:
            val_norm.obs_rms = copy.deepcopy(venv.obs_rms)

        progress = callbacks.Progress(o["steps"], False if args.no_progress else None)
        best = _Best(out / "best", config, venv, args.command_line)

        def on_scores(step: int, scores: dict[str, float]) -> None:
            progress.show({"val success": scores["success_rate"],
                           "collisions": scores["collision_rate"]})
            best.offer(model, step, scores)

        validate = callbacks.Validation(
            validation, range(VALIDATION_SEED, VALIDATION_SEED + o["eval_seeds"]),
            o["eval_every"], sync, on_scores)
        checkpoint = callbacks.Checkpoint(checkpoints, o["checkpoint_every"], venv)
        learn_start = time.perf_counter()
        model.learn(total_timesteps=o["steps"] - steps_from, reset_num_timesteps=False,
                    callback=[progress, callbacks.EpisodeStats(), validate, checkpoint])
        learn_s = time.perf_counter() - learn_start
    finally:
        envs.close()
        if validation is not None:
            validation.close()

    steps = model.num_timesteps - steps_from
    training_s = learn_s - validate.seconds - checkpoint.seconds
    session.update(steps=[steps_from, model.num_timesteps], wall_s=round(time.time() - started),
                   validation_s=round(validate.seconds), throughput={
                       "bare_vec_env_steps_per_s": round(bare, 1),
                       "training_steps_per_s": round(steps / training_s, 1),
                       "ratio": round(steps / training_s / bare, 3)})
    policies.save(out, model, config, policies.Normalizer.of(venv),
                  steps=model.num_timesteps, command=args.command_line,
                  validation=best.last, version=__version__)
    curve.learning_curve(out, f"{out.name}: {config.algo.upper()} on {config.obs}"
                         + (f" ({config.model}/{config.preset})" if config.model else ""))
    _write_record(out, options, config, kwargs, [*sessions, session], "complete")
    write_text_atomic(out / "summary.md", summary_markdown(out))
    print(summary_markdown(out), end="")
    print(f"wrote {out}/: policy.zip, policy.json, best/, learning_curve.png, summary.md, "
          "run.json, logs/, checkpoints/")
    return 0


def _load_checkpoint(folder: Path, venv: Any, algo: str) -> tuple[Any, Any]:
    """The VecNormalize (around `venv`) and the model of the checkpoint in `folder`."""
    from stable_baselines3.common.vec_env import VecNormalize

    cls = getattr(require("stable_baselines3", "rl"), ALGOS[algo])
    try:
        normalized = VecNormalize.load(str(folder / "vecnormalize.pkl"), venv)
        model = cls.load(folder / "model.zip", env=normalized, device="cpu")
    except (AssertionError, ValueError) as exc:  # SB3 asserts that the spaces match
        raise ValueError(f"the checkpoint in {folder} does not fit the environment as it is "
                         f"now (it changed since the run started?): {exc}") from None
    if (folder / "replay_buffer.pkl").is_file():
        model.load_replay_buffer(folder / "replay_buffer.pkl")
    return normalized, model


def _checkpoint_steps(folder: Path) -> int:
    return int(json.loads((folder / "state.json").read_text())["num_timesteps"])


def _write_record(out: Path, options: dict[str, Any], config: PolicyConfig,
                  kwargs: dict[str, Any], sessions: list[dict[str, Any]], status: str) -> None:
    write_text_atomic(out / "run.json", json.dumps({
        "options": options, "policy": config.to_json(), "hyperparameters": kwargs,
        "seeds": {"training": "from the first of each session's env_seeds",
                  "validation": [VALIDATION_SEED, options["eval_seeds"]], "test": "from 1000"},
        "status": status, "sessions": sessions}, indent=1, default=str))


class _Best:
    """Keeps ``folder`` (a policy folder) at the validation's best score so far: success
    rate minus collision rate, then return; a resumed run starts from the saved best."""

    def __init__(self, folder: Path, config: PolicyConfig, venv: Any, command: str) -> None:
        self.folder, self.config, self.venv, self.command = folder, config, venv, command
        self.last: dict[str, Any] | None = None
        try:
            saved = json.loads((folder / "policy.json").read_text())["trained"]["validation"]
            self.score = self._score(saved["scores"])
        except (OSError, ValueError, KeyError, TypeError):
            self.score = (-math.inf, -math.inf)

    @staticmethod
    def _score(scores: Mapping[str, float]) -> tuple[float, float]:
        return (scores["success_rate"] - scores["collision_rate"], scores["mean_reward"])

    def offer(self, model: Any, step: int, scores: dict[str, float]) -> None:
        from lgmd_sim.training import policy as policies

        self.last = {"step": step, "scores": scores}
        if self._score(scores) > self.score:
            self.score = self._score(scores)
            policies.save(self.folder, model, self.config, policies.Normalizer.of(self.venv),
                          steps=step, command=self.command, validation=self.last,
                          version=__version__)


def summary_markdown(folder: Path) -> str:
    """The run in `folder` as Markdown: what was trained, how fast, how it validated."""
    record = json.loads((folder / "run.json").read_text())
    o = record["options"]
    detector = f", {o['model']}/{o['preset']}" if o["model"] else ""
    trained = json.loads((folder / "policy.json").read_text())["trained"]
    lines = [f"# {folder.name}: {o['algo'].upper()} on {o['obs']}{detector}, {o['env']} at "
             f"jitter {o['jitter']:g}, {o['envs']} environments", "",
             "| session | steps | wall time (min) | training steps/s | bare VecEnv steps/s "
             "| ratio |", "|---:|---:|---:|---:|---:|---:|"]
    for i, s in enumerate(record["sessions"]):
        if "throughput" in s:
            t = s["throughput"]
            lines.append(f"| {i} | {s['steps'][0]:,} to {s['steps'][1]:,} | "
                         f"{s['wall_s'] / 60:.1f} | {t['training_steps_per_s']:.0f} | "
                         f"{t['bare_vec_env_steps_per_s']:.0f} | {t['ratio']:.2f} |")
    lines += ["", f"Validation ({o['eval_seeds']} held-out seeds from {VALIDATION_SEED}, "
              f"deterministic policy):", "",
              "| policy | at step | success rate | collision rate | mean distance (m) | "
              "mean return |", "|---|---:|---:|---:|---:|---:|"]
    best_file = folder / "best" / "policy.json"
    rows = [("final", trained.get("validation"))]
    if best_file.is_file():
        rows.append(("best", json.loads(best_file.read_text())["trained"]["validation"]))
    for name, v in rows:
        if v:
            s = v["scores"]
            lines.append(f"| {name} | {v['step']:,} | {s['success_rate']:.2f} | "
                         f"{s['collision_rate']:.2f} | {s['mean_distance_m']:.2f} | "
                         f"{s['mean_reward']:.2f} |")
    return "\n".join(lines) + "\n"
