"""How the benchmark's goal episodes end, ReactiveAvoid against LoomSteer on the same
detectors and seeds: the goal reached, timed out, or a collision, split by when the last
alarm before it came (none; less than 0.6 s before; 0.6-1.15 s, the robot objective's
window; more than 1.15 s). Reads the kept episodes.csv of each entry's goal track; writes
docs/experiments/figures/loom_outcomes.png and prints the counts as a markdown table.

    .venv/bin/python docs/experiments/tools/loom_outcomes.py            # a few seconds
"""

from __future__ import annotations

import argparse
import csv
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
RUNS = ROOT / "docs/benchmark/runs"
OUT = ROOT / "docs/experiments/figures/loom_outcomes.png"
#: The detectors with a row under both controllers: (ReactiveAvoid's folder, LoomSteer's).
PAIRS = [(d, f"{d}-loom-steer") for d in (
    "lgmd1-robot-image", "lgmd2-robot-imu", "feedback-robot-image",
    "feedback-robot-open-loop-image")]
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


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jitter", type=float, default=1.0)
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bars = [(f"{a.replace('-robot', '/robot')}\n{c}", counts(f, args.jitter))
            for a, b in PAIRS for c, f in (("ReactiveAvoid", a), ("LoomSteer", b))]
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
