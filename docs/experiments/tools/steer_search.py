"""Where `Steer`'s constants come from (lgmd_sim.controllers.steer): its first setting and
seven variations, each driving the search seeds of RoughTerrainObstacles at jitter 1 with
no frames rendered (the controller reads the ground truth only); the one with the most
successes less collisions (then the most successes; the first among equals) is the
default. Held-out seeds are `lgmd-sim bench closed-loop`'s, never these.

    .venv/bin/python docs/experiments/tools/steer_search.py            # about 3 minutes on one core
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

import gymnasium as gym

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import controllers

#: The search seeds: neither `lgmd-sim train`'s (training, validation from 900) nor
#: `lgmd-sim bench closed-loop`'s (1000 and up; 50 by default, 30 with --policies).
SEEDS = range(2000, 2030)
#: The first setting ({}: the values it was designed with) and its variations.
SETTINGS: list[dict[str, float]] = [
    {}, {"avoid_distance": 1.6}, {"threat_gain": 4.0}, {"avoid_ttc": 2.0, "avoid_distance": 1.0},
    {"ahead": 90.0, "avoid_distance": 1.5, "threat_gain": 3.5}, {"ahead": 90.0},
    {"ahead": 90.0, "avoid_distance": 1.5}, {"ahead": 90.0, "threat_gain": 3.5},
]
#: The first setting's `ahead`: the variations above are relative to it.
DESIGNED = {"ahead": 75.0}


def score(setting: dict[str, float], seeds: Sequence[int]) -> tuple[float, float]:
    """Shares of episodes reaching the goal and colliding."""
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", jitter=1.0, frame="none")
    reached = collided = 0
    try:
        for seed in seeds:
            *_, last = controllers.rollout(env, controllers.make(
                "steer", **{**DESIGNED, **setting}), seed=seed)
            reached += bool(last.info["goal_reached"])
            collided += last.info["first_collision_frame"] >= 0
    finally:
        env.close()
    return reached / len(seeds), collided / len(seeds)


def main(argv: Sequence[str] | None = None) -> None:
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args(argv)
    rows = [(setting, *score(setting, SEEDS)) for setting in SETTINGS]
    print(f"| setting (over {DESIGNED}) | success | collisions |\n|---|---:|---:|")
    for setting, reached, collided in rows:
        print(f"| {setting or 'as designed'} | {reached:.2f} | {collided:.2f} |")
    best = max(rows, key=lambda r: (r[1] - r[2], r[1]))
    print(f"\nchosen: {best[0]} (seeds {SEEDS.start}-{SEEDS.stop - 1})")


if __name__ == "__main__":
    main()
