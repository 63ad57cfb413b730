"""ReactiveAvoid against LoomSteer on the same detectors and the benchmark's seeds: the
figures issue 43's targets name (goal track at jitter 1 and 2, arena track at jitter 1,
from each entry's result.json), and how the goal episodes at jitter 1 end: the goal
reached, timed out, or a collision, split by when the last alarm before it came (none;
less than 0.6 s before; 0.6-1.15 s, the robot objective's window; more than 1.15 s;
from each goal track's episodes.csv: a record the repository does not keep; the command
in the row's result.json makes it again). Prints them as markdown tables, with the
student policies' figures and the paired differences the page quotes, and writes the
outcomes as docs/experiments/figures/loom_outcomes.png.

    .venv/bin/python docs/experiments/tools/loom_outcomes.py            # a few seconds
"""

from __future__ import annotations

import argparse
import csv
import json
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
RUNS = ROOT / "docs/benchmark/runs"
OUT = ROOT / "docs/experiments/figures/loom_outcomes.png"
#: The detectors LoomSteer was benchmarked with: (ReactiveAvoid's folder, LoomSteer's). The
#: feedback LGMD's open-loop control has no ReactiveAvoid row: its bar is left out.
PAIRS = [(d, f"{d}-loom-steer") for d in (
    "lgmd1-robot-image", "lgmd2-robot-imu", "f_on-robot-image",
    "feedback-robot-image", "feedback-robot-open-loop-image")]


def _folders() -> list[tuple[str, str]]:
    """(controller, folder) of every row of `PAIRS` that was run."""
    return [(c, f) for pair in PAIRS for c, f in zip(("ReactiveAvoid", "LoomSteer"), pair,
                                                      strict=True)
            if (RUNS / f / "result.json").is_file()]


#: The robot objective's window of times to collision (s): lgmd_sim.calibration.robot.
WINDOW = (0.6, 1.15)
OUTCOMES = ("goal reached", "timed out", "collided: no alarm",
            f"collided: last alarm < {WINDOW[0]:g} s before",
            f"collided: last alarm {WINDOW[0]:g}-{WINDOW[1]:g} s before",
            f"collided: last alarm > {WINDOW[1]:g} s before")
#: One colour an outcome (Okabe-Ito), the good ones cool, the collisions warm.
COLOURS = ("#009E73", "#999999", "#000000", "#D55E00", "#E69F00", "#CC79A7")


def outcome(row: dict[str, str]) -> str:
    """Which of `OUTCOMES` an episode of episodes.csv is."""
    if row["goal_reached"] == "True":
        return OUTCOMES[0]
    if row["collided"] != "True":
        return OUTCOMES[1]
    if not row["lead_time_s"]:
        return OUTCOMES[2]
    lead = float(row["lead_time_s"])
    return OUTCOMES[3 if lead < WINDOW[0] else 4 if lead <= WINDOW[1] else 5]


def counts(folder: str, jitter: float) -> dict[str, int]:
    """The outcomes of an entry's goal episodes at one jitter level."""
    with open(RUNS / folder / "goal" / "episodes.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if float(r["jitter"]) == jitter]
    return {o: sum(outcome(r) == o for r in rows) for o in OUTCOMES}


def _pct(value: float, ci: Sequence[float] | None = None) -> str:
    shown = f"{100 * value:.0f}"
    return shown if ci is None else f"{shown} [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]"


def targets() -> str:
    """The targets' figures of every entry of `PAIRS`, a markdown table."""
    from lgmd_sim.benchmark import protocol

    reference = protocol.load("v1").arena.reference_distance_m[1]
    lines = ["| entry | overall | goal j1: success % | goal j1: collisions % | "
             "goal j2: success % | arena j1: avoided % | arena j1: distance / Oracle's |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for _, folder in _folders():
        r = json.loads((RUNS / folder / "result.json").read_text())
        goal, arena = r["metrics"]["goal"], r["metrics"]["arena"]
        g1, g2, a1 = goal["1"], goal["2"], arena["1"]
        low, high = r["intervals"]["overall"]
        lines.append(
            f"| `{r['entry']['label']}` | {r['scores']['overall']:.2f} [{low:.2f}, {high:.2f}] | "
            f"{_pct(g1['success_rate'], g1['success_ci'])} | "
            f"{_pct(g1['collision_rate'], g1['collision_ci'])} | "
            f"{_pct(g2['success_rate'], g2['success_ci'])} | "
            f"{_pct(a1['avoidance_rate'], a1['avoidance_ci'])} | "
            f"{a1['mean_distance_m'] / reference:.2f} |")
    return "\n".join(lines)


#: The student policies held to issue 43's target (15% or fewer collisions at jitter 1,
#: success no lower than the shipped one's): result folders, the shipped one first.
STUDENTS = ("policy_feedback-student", "policy_student-feedback-h4-memory-best")


def students() -> str:
    """The goal track's figures of every one of `STUDENTS`, a markdown table."""
    lines = ["| policy | goal j1: success % | goal j1: collisions % | goal j2: success % | "
             "goal j2: collisions % |", "|---|---:|---:|---:|---:|"]
    for folder in STUDENTS:
        r = json.loads((RUNS / folder / "result.json").read_text())
        g = r["metrics"]["goal"]
        lines.append(f"| `{r['entry']['label']}` | " + " | ".join(
            _pct(g[j][f"{k}_rate"], g[j][f"{k}_ci"]) for j in ("1", "2")
            for k in ("success", "collision")) + " |")
    return "\n".join(lines)


#: The paired comparisons the page quotes: (entry, against), result folders.
PAIRED = [("lgmd1-robot-image-loom-steer", "lgmd1-robot-image"),
          ("lgmd1-robot-image-loom-steer", "lgmd1-robot-image-eyes"),
          ("lgmd2-robot-imu-loom-steer", "lgmd2-robot-imu"),
          ("feedback-robot-image-loom-steer", "feedback-robot-image"),
          ("feedback-robot-image-loom-steer", "feedback-robot-open-loop-image-loom-steer"),
          ("f_on-robot-image-loom-steer", "f_on-robot-image"),
          ("policy_student-feedback-h4-memory-best", "policy_feedback-student")]


def paired() -> str:
    """The score's difference of each of `PAIRED`, paired on the seeds, with the
    leaderboard's bootstrap (`lgmd_sim.benchmark.scores.compare`), a markdown table: the
    overall score, or the goal track's for policies (they have no arena)."""
    from lgmd_sim.benchmark import protocol, scores
    from lgmd_sim.benchmark.leaderboard import load_result, parts

    proto = protocol.load("v1")
    lines = ["| entry | against | score | difference [95% interval] | told apart |",
             "|---|---|---|---|---|"]
    for a, b in PAIRED:
        ra, rb = (load_result(RUNS / f / "result.json") for f in (a, b))
        c = scores.compare(parts(ra), parts(rb), proto.bootstrap, proto.bootstrap_seed)
        key = "overall" if "overall" in c else "goal"
        low, high = c[key]["interval"]
        lines.append(f"| `{ra['entry']['label']}` | `{rb['entry']['label']}` | {key} | "
                     f"{c[key]['difference']:+.2f} [{low:+.2f}, {high:+.2f}] | "
                     f"{'yes' if c[key]['separable'] else 'no'} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jitter", type=float, default=1.0)
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    print(targets() + "\n")
    print(students() + "\n")
    print(paired() + "\n")
    bars = [(f"{f.removesuffix('-loom-steer').replace('-robot', '/robot')}\n{c}",
             counts(f, args.jitter)) for c, f in _folders()]
    print("| entry | controller | " + " | ".join(OUTCOMES) + " |")
    print("|---|---|" + "---:|" * len(OUTCOMES))
    for label, got in bars:
        detector, controller = label.split("\n")
        print(f"| {detector} | {controller} | " + " | ".join(str(got[o]) for o in OUTCOMES)
              + " |")
    fig, ax = plt.subplots(figsize=(9, 4.8), layout="constrained")
    y = list(range(len(bars)))[::-1]
    left = [0] * len(bars)
    for o, colour in zip(OUTCOMES, COLOURS, strict=True):
        widths = [got[o] for _, got in bars]
        ax.barh(y, widths, left=left, color=colour, label=o, edgecolor="white")
        left = [a + b for a, b in zip(left, widths, strict=True)]
    ax.set_yticks(y, [label.replace("\n", "  ") for label, _ in bars], fontsize="small")
    ax.set(xlabel=f"goal episodes at jitter {args.jitter:g} (benchmark test seeds)",
           title="How the goal episodes end: ReactiveAvoid and LoomSteer, same detectors")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncols=3, fontsize="small",
              frameon=False)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=120)
    print(f"\nwrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
