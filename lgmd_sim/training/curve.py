"""The learning curve of a training run, from its logs (``DIR/logs/session-*/progress.csv``,
stable-baselines3's CSV log, one per training session)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from lgmd_sim.core.fileio import write_files
from lgmd_sim.core.plots import figure

__all__ = ["PANELS", "learning_curve", "phase_changes", "read_logs"]

#: Panel title -> (training key: the last 100 training episodes, validation key).
PANELS = {
    "episode return": ("rollout/ep_rew_mean", "eval/mean_reward"),
    "success rate": ("rollout/success_rate", "eval/success_rate"),
    "collision rate": ("rollout/collision_rate", "eval/collision_rate"),
}


def read_logs(folder: Path) -> dict[str, np.ndarray]:
    """Every logged series of the run in `folder` as (steps, values) rows, sessions
    concatenated in step order."""
    series: dict[str, list[tuple[float, float]]] = {}
    for path in sorted((folder / "logs").glob("session-*/progress.csv")):
        with path.open(newline="") as f:
            for row in csv.DictReader(f):
                step = _number(row.get("time/total_timesteps"))
                if step is None:
                    continue
                for key, text in row.items():
                    value = _number(text)
                    if value is not None and key != "time/total_timesteps":
                        series.setdefault(key, []).append((step, value))
    return {k: np.array(sorted(v)) for k, v in series.items()}


def _number(text: str | None) -> float | None:
    try:
        value = float(text) if text else None
    except ValueError:
        return None
    return value if value is not None and math.isfinite(value) else None


def phase_changes(folder: Path) -> list[tuple[float, str]]:
    """(step, label) where the run of `folder` changed what it trained on: the end of its
    DAgger rounds (RL from there), the end of its value warm-up (the policy learns again
    from there) and each curriculum stage passed (from its run.json; ValueError naming it
    where it is not a training run's, `lgmd_sim.training.summary.run_record`)."""
    from lgmd_sim.training.summary import run_record

    sessions = run_record(folder)["sessions"]
    changes = []
    rounds = [r for s in sessions for r in s.get("imitation", [])]
    if rounds:
        changes.append((rounds[-1]["steps"], "DAgger ends"))
    changes += [(s["value_warmup"]["steps"][1], "value warm-up ends") for s in sessions
                if "value_warmup" in s]
    changes += [(st["steps"][1], f"stage {st['stage'] + 1} passed")
                for s in sessions for st in s.get("stages", []) if st["passed"]]
    return changes


def learning_curve(folder: Path, title: str = "") -> Path:
    """Draw ``folder/learning_curve.png``: episode return, success rate and collision rate
    against environment steps, of the training episodes (a running mean over the last
    100) and of the validation episodes (fixed held-out seeds, deterministic policy),
    with a dotted line where DAgger or the value warm-up ended or a curriculum stage was
    passed."""
    from matplotlib.ticker import EngFormatter

    logs = read_logs(folder)
    changes = phase_changes(folder)
    fig = figure(figsize=(12, 3.6))
    for ax, (name, (train_key, eval_key)) in zip(fig.subplots(1, 3), PANELS.items(),
                                                   strict=True):
        if train_key in logs:
            ax.plot(*logs[train_key].T, color="0.55", lw=1.2, label="training (last 100)")
        if eval_key in logs:
            ax.plot(*logs[eval_key].T, color="C3", marker="o", ms=4, lw=1.4,
                    label="validation (held-out seeds)")
        for step, label in changes:
            ax.axvline(step, color="0.3", ls=":", lw=1)
            ax.annotate(label, (step, 1), xycoords=("data", "axes fraction"), rotation=90,
                        va="top", ha="right", fontsize="x-small", color="0.3")
        if "rate" in name:
            ax.set_ylim(-0.03, 1.03)
        # "300k", not "300000": six-digit ticks ran into each other
        ax.xaxis.set_major_formatter(EngFormatter(sep=""))
        ax.set_xlabel("environment steps")
        ax.set_title(name, fontsize="medium")
        ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    if title:
        fig.suptitle(title, fontsize="medium")
    path = folder / "learning_curve.png"
    write_files({path: lambda tmp: fig.savefig(tmp, format="png", dpi=110)})
    return path
