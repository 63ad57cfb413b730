"""How much of the Oracle's decision a DAgger student's observation carries: the imitation
gap of a run trained with ``teacher = "oracle"`` (``lgmd-sim train --config``), measured on the
states it labelled (its ``checkpoints/dagger.npz``).

The Oracle's manoeuvre starts when the ground truth puts the threat in its trigger zone;
a student that cannot tell when that is learns the mean of the teacher's actions over the
states it cannot tell apart, which neither turns nor brakes in time. On the cruise steps
(the Oracle neither turning away nor driving on past an obstacle), a small classifier
predicts whether the Oracle starts its manoeuvre within `WITHIN` steps, from the
proprioception and goal alone, from the detector's features alone, and from both: its
ROC AUC on held-out labels, per feature set: the mean over `FOLDS` folds of contiguous
stretches of the labels (each held out in turn), with the lowest and highest.
The detector's features add to the proprioception and goal what their difference in AUC
says; 0.5 is chance. Also: the share of the Oracle's manoeuvre onsets at which the
detector's alarm was on, against its share of the other cruise steps.

    .venv/bin/python docs/experiments/tools/imitation_gap.py runs/train/student-lgmd1 [RUN ...]
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lgmd_sim.controllers.avoid import OracleParams
from lgmd_sim.signals.metrics import roc_auc
from lgmd_sim.training.dagger import Labels

#: "The Oracle starts its manoeuvre within": this step or the next 6 (0.2 s at the task's
#: 30 frames per second), about the time the detector's potential takes to rise (design).
WITHIN = 6
#: The classifier (design): a 64 x 64 tanh MLP, as the policies' own, by Adam on the
#: cross-entropy; fixed seed, so the figures are the same on each run.
HIDDEN, EPOCHS, BATCH, LEARNING_RATE, SEED = 64, 12, 512, 1e-3, 0
#: Cross-validation folds, each a contiguous stretch of the labels (neighbouring steps are
#: nearly alike: a random split would test on near-copies of training rows).
FOLDS = 5
AGENT_KEYS = ("proprio", "goal")


@dataclass(frozen=True)
class Gap:
    """The imitation gap of one run."""

    run: str
    model: str
    cruise_steps: int
    onsets: int
    auc: dict[str, tuple[float, float, float]]  # per feature set: mean, lowest, highest
    alarm_at_onsets: float | None  # share of onsets with the alarm on (None: no alarm key)
    alarm_otherwise: float | None


def _held_out_auc(x: np.ndarray, y: np.ndarray, train: np.ndarray, test: np.ndarray) -> float:
    import torch

    torch.manual_seed(SEED)
    mean, std = x[train].mean(0), x[train].std(0) + 1e-6
    x = torch.as_tensor((x - mean) / std, dtype=torch.float32)
    target = torch.as_tensor(y, dtype=torch.float32)
    net = torch.nn.Sequential(torch.nn.Linear(x.shape[1], HIDDEN), torch.nn.Tanh(),
                              torch.nn.Linear(HIDDEN, HIDDEN), torch.nn.Tanh(),
                              torch.nn.Linear(HIDDEN, 1))
    optimizer = torch.optim.Adam(net.parameters(), lr=LEARNING_RATE)
    rows = torch.as_tensor(train)
    for _ in range(EPOCHS):
        for batch in rows[torch.randperm(len(rows))].split(BATCH):
            loss = torch.nn.functional.binary_cross_entropy_with_logits(
                net(x[batch])[:, 0], target[batch])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
    with torch.no_grad():
        auc = roc_auc(net(x[test])[:, 0].numpy(), y[test])
    if auc is None:
        raise SystemExit("imitation_gap.py: a fold without an onset of the Oracle's manoeuvre "
                         "(too few labels)")
    return auc


def gap(run: Path) -> Gap:
    """The imitation gap of the DAgger run in `run` (teacher: the Oracle)."""
    record = json.loads((run / "run.json").read_text())
    config = record["config"]
    if config.get("teacher") != "oracle" or config.get("obs") != "features":
        raise SystemExit(f"imitation_gap.py: {run} is not a run on features with "
                         "teacher = \"oracle\"")
    labels = Labels.load(run / "checkpoints" / "dagger.npz")
    obs = {k: v.reshape(len(v), -1) for k, v in labels.obs.items()}
    actions = labels.actions
    p, envs = OracleParams(), config["envs"]
    turning = np.isclose(actions[:, 0], p.avoid_speed) & np.isclose(np.abs(actions[:, 1]),
                                                                    p.avoid_turn)
    passing = np.isclose(actions[:, 0], p.cruise) & (actions[:, 1] == 0)
    # rows are step-major over the environments, round after round: a round's streams
    # start afresh, so the look-ahead stays inside each round's block
    per_round = config["imitation_steps"] // config["dagger_rounds"] // envs * envs
    onset, soon = np.zeros_like(turning), np.zeros_like(turning)
    for start in range(0, len(actions) - per_round + 1, per_round):
        block = turning[start:start + per_round].reshape(-1, envs)
        starts = block & ~np.vstack([np.zeros((1, envs), bool), block[:-1]])
        ahead = np.zeros_like(starts)
        for k in range(WITHIN + 1):
            ahead[:len(starts) - k] |= starts[k:]
        onset[start:start + per_round] = starts.reshape(-1)
        soon[start:start + per_round] = ahead.reshape(-1)
    cruise = np.flatnonzero(~turning & ~passing | onset)
    folds = np.array_split(np.arange(len(cruise)), FOLDS)
    own = sorted(k for k in obs if k not in AGENT_KEYS)
    sets = {"proprioception and goal": list(AGENT_KEYS), "detector's features": own,
            "both": [*AGENT_KEYS, *own]}
    y = soon[cruise]
    auc = {}
    for name, keys in sets.items():
        x = np.concatenate([obs[k][cruise] for k in keys], 1)
        scores = [_held_out_auc(x, y, np.concatenate(folds[:i] + folds[i + 1:]), test)
                  for i, test in enumerate(folds)]
        auc[name] = (float(np.mean(scores)), min(scores), max(scores))
    alarm = obs.get("lgmd_alarm")
    on = None if alarm is None else alarm[:, 0] > 0.5
    return Gap(run.name, f"{config['model']}/{config['preset']}", len(cruise),
               int(onset.sum()), auc,
               None if on is None else float(on[onset].mean()),
               None if on is None else float(on[cruise][~onset[cruise]].mean()))


def table(gaps: list[Gap]) -> list[str]:
    """The gaps as a Markdown table."""
    names = list(gaps[0].auc)
    lines = [f"ROC AUC: mean [lowest, highest] of {FOLDS} folds.", "",
             "| run | detector | cruise steps | Oracle's onsets | "
             + " | ".join(f"AUC: {n}" for n in names)
             + " | alarm on at onsets | alarm on at other cruise steps |",
             "|---|---|---:|---:|" + "---:|" * len(names) + "---:|---:|"]
    for g in gaps:
        alarm = ("n/a | n/a" if g.alarm_at_onsets is None else
                 f"{100 * g.alarm_at_onsets:.0f}% | {100 * g.alarm_otherwise:.0f}%")
        lines.append(f"| {g.run} | {g.model} | {g.cruise_steps:,} | {g.onsets:,} | "
                     + " | ".join(f"{m:.2f} [{lo:.2f}, {hi:.2f}]" for m, lo, hi in
                                  (g.auc[n] for n in names)) + f" | {alarm} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", type=Path, nargs="+")
    args = parser.parse_args()
    print("\n".join(table([gap(run) for run in args.runs])))


if __name__ == "__main__":
    main()
