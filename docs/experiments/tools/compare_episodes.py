"""How many episodes two runs of the closed-loop bench (or eval) played otherwise: for each
cell, the episodes both hold whose frames, distance, alarms or clearance differ, and how
many of those ended otherwise (collided, reached the goal). For the same command on two
machines: zero means the machines agree bit for bit.

    python docs/experiments/tools/compare_episodes.py RUN_A/episodes.csv RUN_B/episodes.csv
"""

from __future__ import annotations

import argparse
import csv
from collections import Counter
from pathlib import Path

#: What an episode's record must match to have been played the same way.
PLAYED = ("frames", "distance_m", "alarms", "min_clearance_m")
#: How an episode ended.
OUTCOME = ("collided", "goal_reached")
CELL = ("controller", "model", "preset", "tag", "scenario", "jitter")


def _episodes(file: Path) -> dict[tuple[str, ...], dict[str, str]]:
    with file.open() as f:
        return {tuple(r[k] for k in (*CELL, "seed")): r for r in csv.DictReader(f)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", type=Path)
    parser.add_argument("b", type=Path)
    args = parser.parse_args()
    a, b = _episodes(args.a), _episodes(args.b)
    both, otherwise, ended = Counter(), Counter(), Counter()
    for key in sorted(a.keys() & b.keys()):
        cell = key[:-1]
        both[cell] += 1
        if any(a[key][c] != b[key][c] for c in PLAYED):
            otherwise[cell] += 1
            ended[cell] += any(a[key][c] != b[key][c] for c in OUTCOME)
    print("| cell | episodes in both | played otherwise | ended otherwise |")
    print("|---|---:|---:|---:|")
    for cell in sorted(both):
        name = " ".join(v for v in cell if v)
        print(f"| {name} | {both[cell]} | {otherwise[cell]} | {ended[cell]} |")


if __name__ == "__main__":
    main()
