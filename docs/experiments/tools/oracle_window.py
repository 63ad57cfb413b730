"""How early must the avoidance manoeuvre start? The Oracle at a range of trigger horizons.

The robot calibration's objective asks for an alarm while the threat's time to collision
lies in a window (`lgmd_sim.calibration.robot`); this measures where that window is: the
Oracle (the manoeuvre triggered by ground truth) triggered at each time to collision in
HORIZONS, on seeds that are neither the calibration's nor the benchmark's held-out ones.

    python docs/experiments/tools/oracle_window.py runs/oracle-window [--seeds 20] [--jitter 1]

Writes the run folder (resumable: run again to finish it), prints its summary and the
window: the trigger horizons at which the Oracle itself meets the issue's target at
jitter 1 (goal reached in SUCCESS or more of the episodes, collisions in COLLISIONS or
fewer), from the lowest such horizon to the highest.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig, run
from lgmd_sim.benchmark.episode import Cell
from lgmd_sim.core.parallel import RunOptions

HORIZONS = (0.3, 0.45, 0.6, 0.8, 1.0, 1.15, 1.3, 1.7, 2.2)
#: Seeds 200 and up: not the calibration's (0-7, 100-107) nor the benchmark's (1000-1049).
FIRST_SEED = 200
#: The closed-loop target at jitter 1 (issue 16; docs/experiments/results-log.md): success
#: and collision rates.
SUCCESS, COLLISIONS = 0.60, 0.15


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--jitter", default="1")
    parser.add_argument("--scenario", default="RoughTerrainObstacles")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args()
    jitters = tuple(float(j) for j in args.jitter.split(","))
    cells = tuple(Cell(args.scenario, j, "oracle", params=(("horizon", h),), tag=f"horizon {h:g}")
                  for j in jitters for h in HORIZONS)
    config = ClosedLoopConfig(scenarios=(args.scenario,), jitter=jitters, controllers=(),
                              seeds=args.seeds, first_seed=FIRST_SEED, extra=cells)
    result = run(config, args.out, RunOptions(workers=args.workers, progress=False, resume=True,
                                              command=shlex.join(["python", *sys.argv])))
    rows = sorted(result.rows, key=lambda r: (r["jitter"], horizon(r)))
    for row in rows:
        print(f"jitter {row['jitter']:g} {row['tag']:>12}: success {row['success_rate']:.2f} "
              f"collisions {row['collision_rate']:.2f} progress {row['mean_progress']:.2f}")
    for j in jitters:
        found = window([r for r in rows if r["jitter"] == j])
        print(f"jitter {j:g}: the Oracle meets the target when triggered at a time to "
              f"collision of {found[0]:g} to {found[1]:g} s" if found else
              f"jitter {j:g}: the Oracle meets the target at no horizon tried")


def horizon(row: dict) -> float:
    """The trigger horizon of a summary row (its cell's tag)."""
    return float(row["tag"].removeprefix("horizon "))


def window(rows: list[dict]) -> tuple[float, float] | None:
    """The lowest and highest horizon among one jitter level's rows (summary rows, or
    summary.csv's) at which the Oracle meets the target; None: at none."""
    good = [horizon(r) for r in rows if float(r["success_rate"]) >= SUCCESS
            and float(r["collision_rate"]) <= COLLISIONS]
    return (min(good), max(good)) if good else None


if __name__ == "__main__":
    main()
