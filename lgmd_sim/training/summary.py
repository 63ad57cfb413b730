"""A training run's summary (``summary.md``), from its folder: what was trained, how
fast, how DAgger's rounds and PPO's updates went, how it validated."""

from __future__ import annotations

import csv
import statistics
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from lgmd_sim.core.runs import NULL, NUMBER, RECORD, Fields, Maybe, read_record
from lgmd_sim.policies.config import PolicyConfig
from lgmd_sim.training.dagger import FIT_EPOCHS

__all__ = ["RECORD_FIELDS", "grid_text", "run_record", "summary_markdown", "trained",
           "update_sizes", "validation_rows"]

#: What resuming, the summary and the learning curve read of a training run's run.json
#: (the options, under "config", are checked as a `TrainConfig`); a record holding
#: something else is refused naming the file, not met as a traceback after the training.
RECORD_FIELDS: Fields = {
    "config": dict,
    "sessions": [{
        "env_seeds": [int],
        "steps": Maybe([int]),
        "wall_time_s": Maybe(NUMBER),
        "throughput": Maybe({k: NUMBER for k in ("training_steps_per_s",
                                                 "bare_vec_env_steps_per_s", "ratio")}),
        "stages": Maybe([{"stage": int, "overrides": dict, "steps": [int], "episodes": int,
                          "success_rate": (NUMBER, NULL), "passed": bool}]),
        "imitation": Maybe([{k: NUMBER for k in ("round", "beta", "steps", "labels",
                                                 "bc_loss", "val_success", "val_collision")}]),
        "value_warmup": Maybe({"steps": [int], "n_updates": [int]}),
    }],
    "curriculum": Maybe({"window": int, "stage": [dict]}),
    "seeds": Maybe({"validation": [int]}),
}
#: What the summary reads of a policy folder's policy.json.
_POLICY_FIELDS: Fields = {"trained": {"validation": Maybe((NULL, {
    "step": int, "scores": {k: NUMBER for k in ("success_rate", "collision_rate",
                                                 "mean_distance_m", "mean_reward")}}))}}
#: What a user can do about a record or policy that is not what the run wrote.
_REMEDY = "train again in a new folder"


def run_record(folder: str | Path) -> dict[str, Any]:
    """The record (run.json) of the training run in `folder`.

    Raises:
        ValueError: one that cannot be read, is larger than `lgmd_sim.core.fileio.TEXT_LIMIT`
            or does not hold `RECORD_FIELDS` (one line naming the file).
    """
    return read_record(Path(folder) / RECORD, RECORD_FIELDS, _REMEDY)


def grid_text(config: dict[str, Any]) -> str:
    """The S-layer grid a run's recorded options chose, in words; "" for the default."""
    grid, frames = (tuple(config.get("grid", PolicyConfig.grid)),
                    config.get("grid_history", PolicyConfig.grid_history))
    memory = config.get("memory", PolicyConfig.memory)
    if (grid, frames, memory) == (PolicyConfig.grid, PolicyConfig.grid_history,
                                  PolicyConfig.memory):
        return ""
    return (f"S-layer grid {grid[0]}x{grid[1]}"
            + (f" over the last {frames} frames" if frames > 1 else "")
            + (f" with a {memory}-frame memory" if memory else ""))


def trained(config: dict[str, Any]) -> str:
    """The algorithm and what the policy sees, from a run's recorded options ("PPO on
    features, lgmd1/robot-image, S-layer grid 3x5")."""
    text = f"{config['algo'].upper()} on {config['obs']}"
    for part in ("/".join(v for v in (config["model"], config["preset"]) if v),
                 grid_text(config)):
        text += f", {part}" if part else ""
    return text


def summary_markdown(folder: Path) -> str:
    """The run in `folder` as Markdown: what was trained, how fast, how it validated.

    Raises:
        ValueError: a run.json or policy.json that is not what the run wrote (one line
            naming the file).
    """
    record = run_record(folder)
    o = record["config"]
    shaped = f"; training reward {', '.join(o['reward'])}" if o.get("reward") else ""
    lines = [f"# {folder.name}: {trained(o)}, {o['env']} at "
             f"jitter {o['jitter']:g}, {o['envs']} environments{shaped}", "",
             "| session | steps | wall time (min) | training steps/s | bare VecEnv steps/s "
             "| ratio |", "|---:|---:|---:|---:|---:|---:|"]
    for i, s in enumerate(record["sessions"]):
        if "throughput" in s:
            t = s["throughput"]
            lines.append(f"| {i} | {s['steps'][0]:,} to {s['steps'][1]:,} | "
                         f"{s['wall_time_s'] / 60:.1f} | {t['training_steps_per_s']:.0f} | "
                         f"{t['bare_vec_env_steps_per_s']:.0f} | {t['ratio']:.2f} |")
    stages = [(i, st) for i, s in enumerate(record["sessions"]) for st in s.get("stages", [])]
    if stages:
        n = len(record["curriculum"]["stage"])
        lines += ["", f"Curriculum {o['curriculum']} (a stage is passed at its success rate "
                  f"over the last {record['curriculum']['window']} training episodes):", "",
                  "| session | stage | environment | steps | episodes | success rate | "
                  "passed |", "|---:|---|---|---:|---:|---:|---|"]
        for i, st in stages:
            env = ", ".join(f"{k}={v}" for k, v in st["overrides"].items()) or "the task's"
            rate = "-" if st["success_rate"] is None else f"{st['success_rate']:.2f}"
            lines.append(f"| {i} | {st['stage'] + 1 if st['stage'] < n else 'task'} | {env} | "
                         f"{st['steps'][0]:,} to {st['steps'][1]:,} | {st['episodes']} | "
                         f"{rate} | {'yes' if st['passed'] else 'no'} |")
    rounds = [(i, r) for i, s in enumerate(record["sessions"]) for r in s.get("imitation", [])]
    if rounds:
        how = "".join([f"; {o['dagger_epochs']} epochs of cloning a round"
                       if o.get("dagger_epochs", FIT_EPOCHS) != FIT_EPOCHS else "",
                       "; the student driving by its mean action"
                       if o.get("dagger_student") == "mean" else ""])
        lines += ["", f"DAgger from {o['teacher']} ({o['imitation_steps']:,} steps in "
                  f"{o['dagger_rounds']} rounds{how}; beta: the share of steps the teacher "
                  "drove; validation after each round):", "",
                  "| session | round | beta | at step | labels | cloning loss | "
                  "val success | val collisions |", "|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for i, r in rounds:
            lines.append(f"| {i} | {r['round']} | {r['beta']:.2f} | {r['steps']:,} | "
                         f"{r['labels']:,} | {r['bc_loss']:.3f} | {r['val_success']:.2f} | "
                         f"{r['val_collision']:.2f} |")
    lines += update_sizes(folder, record)
    lines += ["", f"Validation ({o['eval_seeds']} held-out seeds from "
              f"{record['seeds']['validation'][0]}, deterministic policy):", "",
              "| policy | at step | success rate | collision rate | mean distance (m) | "
              "mean return |", "|---|---:|---:|---:|---:|---:|"]
    for r in validation_rows(folder):
        lines.append(f"| {r['policy']} | {r['step']:,} | {r['success_rate']:.2f} | "
                     f"{r['collision_rate']:.2f} | {r['mean_distance_m']:.2f} | "
                     f"{r['mean_reward']:.2f} |")
    return "\n".join(lines) + "\n"


def update_sizes(folder: Path, record: Mapping[str, Any]) -> list[str]:
    """PPO's updates, per session and phase (the value warm-up, the rest): the median
    approximate KL divergence and clip fraction over its updates, which say how far each
    update moved the policy, and the value function's explained variance. From the
    session's logs (``logs/session-K/progress.csv``); none for SAC or without logs."""
    if record["config"]["algo"] != "ppo":
        return []
    rows = []
    for i, session in enumerate(record["sessions"]):
        log = folder / "logs" / f"session-{i}" / "progress.csv"
        if not log.is_file():
            continue
        with log.open(newline="") as f:
            updates = [r for r in csv.DictReader(f) if r.get("train/approx_kl")]
        # by the update counter: stable-baselines3 logs an update's figures at a later
        # step (the next rollout's, or a validation's)
        first, last = session.get("value_warmup", {}).get("n_updates", [0, 0])
        warmup = [first < float(r["train/n_updates"]) <= last for r in updates]
        phases = {"value warm-up": [r for r, w in zip(updates, warmup, strict=True) if w],
                  "PPO": [r for r, w in zip(updates, warmup, strict=True) if not w]}
        for phase, rs in phases.items():
            if rs:
                steps = [int(r["time/total_timesteps"]) for r in rs]
                med = {k: statistics.median(float(r[f"train/{k}"]) for r in rs)
                       for k in ("approx_kl", "clip_fraction", "explained_variance")}
                kl = round(med["approx_kl"], 3) + 0.0  # no "-0.000" from rounding noise
                rows.append(f"| {i} | {phase} | {min(steps):,} to {max(steps):,} | {len(rs)} | "
                            f"{kl:.3f} | {med['clip_fraction']:.2f} | "
                            f"{med['explained_variance']:.2f} |")
    if not rows:
        return []
    return ["", "PPO's updates (medians over each phase's updates; an approximate KL "
            "far above PPO's usual 0.01 to 0.02 means each update moved the policy far):", "",
            "| session | phase | logged at steps | updates | approx. KL | clip fraction | "
            "explained variance |", "|---:|---|---|---:|---:|---:|---:|", *rows]


def validation_rows(folder: Path) -> list[dict[str, Any]]:
    """The last validation of the final policy and of the best one, where there was one;
    ValueError naming a policy.json that does not hold it."""
    rows = []
    for name, file in (("final", folder / "policy.json"),
                       ("best", folder / "best" / "policy.json")):
        v = (read_record(file, _POLICY_FIELDS, _REMEDY)["trained"].get("validation")
             if file.is_file() else None)
        if v:
            rows.append({"policy": name, "step": v["step"], **v["scores"]})
    return rows
