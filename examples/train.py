"""A tiny training run: PPO learns to drive the robot from an LGMD's outputs, then the
policy is evaluated beside the hand-made controllers on the same seeds.

The Python API of `lgmd-sim train` and `lgmd-sim bench closed-loop --policies` (the same
jobs, the same run folders; docs/guides/training.md). A few hundred steps learn nothing
worth keeping: this shows the calls, the folders and the tables in seconds; a real run is
300,000 steps or more. Needs the `rl` extra (stable-baselines3).

    python examples/train.py --out runs/train-example

Writes OUT/policy (the policy folder: `lgmd-sim bench closed-loop --policies OUT/policy`
and the `policy` controller take it) and OUT/eval (the evaluation: eval.md, summary.csv).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from lgmd_sim.cli.args import error_line
from lgmd_sim.core.extras import MissingExtra
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.core.params import checked, count
from lgmd_sim.detect.outputs import check_out_folder
from lgmd_sim.training.evaluate import EvalConfig, evaluate
from lgmd_sim.training.run import TrainConfig, train


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("train-example"),
                        help="output folder (default ./train-example)")
    parser.add_argument("--scenario", default="RoughTerrainObstacles",
                        help="the task: a scenario name (lgmd-sim envs)")
    parser.add_argument("--steps", type=int, default=256,
                        help="environment steps of training (default 256: seconds)")
    parser.add_argument("--seeds", type=int, default=1,
                        help="evaluation episodes per controller (default 1)")
    args = parser.parse_args()
    try:
        run(args.out, args.scenario, args.steps, args.seeds)
    except (ValueError, OSError, MissingExtra) as exc:  # as lgmd-sim: one line, status 2
        parser.exit(2, f"{parser.prog}: error: {error_line(exc, parser, args)}\n")


def run(out: Path, scenario: str, steps: int, seeds: int) -> None:
    """Train a policy into OUT/policy, then evaluate it into OUT/eval; every option is
    checked before the training starts."""
    check_out_folder(out)
    # the evaluation's configuration can be made only once the policy exists: its seeds
    # are checked now, not after the training
    checked("seeds", seeds, count)
    # PPO on the feedback LGMD's features (its potentials and where in the view its
    # excitation is), with the wheels' and IMU's readings and the goal, at 64 x 64.
    config = TrainConfig(
        algo="ppo", env=f"lgmd_sim/{scenario}-v0", obs="features", model="feedback",
        resolution="small", jitter=1.0, steps=steps,
        envs=1,  # one environment in this process: no worker start-up for a tiny run
        eval_every=steps, eval_seeds=1, checkpoint_every=steps,  # validate once, at the end
        hp=("n_steps=128", "batch_size=64"))  # PPO's rollout fits in the few steps
    trained = train(config, out / "policy", progress=False)
    # the validation on held-out seeds: the final policy's row and the best one's
    for row in trained.rows:
        print(f"validation, {row['policy']} policy at step {row['step']}: success "
              f"{row['success_rate']:.0%}, collisions {row['collision_rate']:.0%}, "
              f"{row['mean_distance_m']:.1f} m travelled")

    # The policy beside Straight (the floor) and the Oracle (the ceiling: it reads the
    # ground truth) on the same seeds and jitter level: eval.md holds the table.
    check = EvalConfig(policies=(str(out / "policy"),), controllers=("straight", "oracle"),
                       jitter=(1.0,), seeds=seeds)
    evaluate(check, out / "eval", RunOptions(workers=1, progress=False))
    print((out / "eval" / "eval.md").read_text())


if __name__ == "__main__":
    main()
