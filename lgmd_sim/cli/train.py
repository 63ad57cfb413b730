"""`lgmd-sim train`: its arguments, and the `TrainConfig` made from them.

Options default to None here so that ``--resume`` can tell the ones given from the ones
recorded: a resumed run takes the recorded ones, and only `RESUMABLE` ones may be given
anew; `TrainConfig`'s defaults are the ones the help text names.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

from lgmd_sim.cli.args import advanced, grid, print_result, resolution
from lgmd_sim.core.extras import install_command


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "train", help="train an avoidance policy with stable-baselines3 (needs the rl extra)",
        description="Train a policy that reads an LGMD model's signals (--obs features: its "
        "potential history, alarm and S-layer grid, with the proprioception and goal; an MLP), "
        "small stacked grey frames (--obs pixels; a CNN) or the ground truth the Oracle "
        "reads (--obs privileged: the threat's distance, bearing, time to collision and "
        "closing speed; an MLP, the upper bound for the others) to drive to the goal without "
        "colliding. Vectorised environments, observation normalisation, validation on fixed "
        "held-out seeds, checkpoints, TensorBoard logs; writes DIR/policy.npz and "
        "policy.json (a policy for lgmd-sim eval), DIR/best/, DIR/learning_curve.png, "
        "DIR/summary.md and DIR/run.json. The reward is the environment's (lgmd-sim envs "
        "NAME). Needs the rl extra, stable-baselines3 and PyTorch (install it "
        f"{install_command('rl')}).",
    )
    p.add_argument("--algo", help="ppo or sac (default ppo)")
    p.add_argument("--env", metavar="ID", help="Gymnasium id of the environment (default "
                   "lgmd_sim/RoughTerrainObstacles-v0)")
    p.add_argument("--obs", help="features, pixels or privileged (default features)")
    p.add_argument("--model", help="the LGMD model of --obs features, MODEL or MODEL/PRESET "
                   "(default feedback)")
    p.add_argument("--preset", help="its preset (default: the model's default)")
    p.add_argument("--steps", type=int, help="environment steps in all, over every "
                   "environment (default 300000); with --resume, the new total")
    p.add_argument("--envs", type=int, metavar="K",
                   help="environments stepped in parallel, one worker process each (default 2)")
    p.add_argument("--seed", type=int, help="seed of the model and of the first training "
                   "environment (default 0; training seeds stay below 900)")
    p.add_argument("--out", metavar="DIR", help="output folder, new or empty (default "
                   "./train-ALGO-OBS)")
    p.add_argument("--resume", metavar="DIR", help="continue the run in DIR from its last "
                   "checkpoint, up to --steps in all")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    more = advanced(p, "the S-layer grid the policy sees, the frames and jitter it trains on, "
                    "validation and checkpoints, the algorithm's hyperparameters, and the "
                    "research methods: reward shaping, a curriculum, learning from a teacher "
                    "(DAgger) before RL")
    more.add_argument("--grid", type=grid, metavar="RxC",
                      help="the S-layer grid of --obs features: rows x columns of cells, each "
                      "holding its share of the layer's activity (default 1x3: left, centre, "
                      "right)")
    more.add_argument("--grid-history", type=int, metavar="K",
                      help="how many of the last grids --obs features observes, oldest first "
                      "(default 1: the present frame's; more show where the activity grows)")
    more.add_argument("--memory", type=int, metavar="N",
                      help="--obs features also observes, per column of the grid, the "
                      "potential's excitation seen there lately, fading over N frames (30: "
                      "a second), for what has left the frame (default 0: none)")
    more.add_argument("--resolution", type=resolution,
                      help="frame size the environment renders: rl (120x160, default, as the "
                      "benchmark), paper, small or HxW")
    more.add_argument("--jitter", type=float, help="jitter level of the training episodes "
                      "(default 1)")
    more.add_argument("--eval-every", type=int, metavar="N",
                      help="validate every N steps (default 25000)")
    more.add_argument("--eval-seeds", type=int, metavar="N",
                      help="validation episodes, seeds 900 to 900 + N - 1 (default 10)")
    more.add_argument("--checkpoint-every", type=int, metavar="N",
                      help="write a checkpoint every N steps (default 25000)")
    more.add_argument("--hp", action="append", metavar="KEY=VALUE",
                      help="override a hyperparameter of the algorithm (repeatable), e.g. "
                      "--hp n_steps=512 --hp learning_rate=1e-4; with --resume, added to the "
                      "run's (not policy_kwargs), e.g. --hp target_kl=0.02 for gentler "
                      "fine-tuning")
    more.add_argument("--reward", action="append", metavar="KEY=VALUE",
                      help="a reward parameter of the training environments (repeatable): "
                      "progress_reward, collision_penalty, effort_penalty, goal_bonus, "
                      "time_penalty or proximity_penalty (lgmd-sim envs NAME lists them; the "
                      "shaping ones are off by default); validation and lgmd-sim eval keep the "
                      "environment's own reward, e.g. --reward goal_bonus=5")
    more.add_argument("--curriculum", metavar="NAME|FILE",
                      help="go through easier versions of the task first, each stage passed "
                      "at a success rate of its training episodes: a built-in curriculum "
                      "(obstacles: no obstacle and the goal 4 m away, then 2 obstacles at 6 m, "
                      "4 at 8 m, then the task) or a TOML file of stages "
                      "(lgmd_sim.training.curriculum); validation always runs on the task")
    more.add_argument("--teacher", metavar="oracle|steer|reactive|POLICY",
                      help="learn from a teacher first, by DAgger: the Oracle controller, "
                      "steer (the Oracle's inputs without its memory: what a policy can copy), "
                      "ReactiveAvoid's manoeuvre on the policy's own LGMD alarm (reactive, "
                      "--obs features), or a privileged policy (a folder trained with --obs "
                      "privileged) labels the states the policy visits, the policy is fitted "
                      "to the labels, then RL fine-tunes it (PPO only)")
    more.add_argument("--imitation-steps", type=int, metavar="N",
                      help="environment steps of the DAgger rounds, part of --steps (default "
                      "100000)")
    more.add_argument("--dagger-rounds", type=int, metavar="K",
                      help="DAgger rounds (default 10): the teacher drives round 0, then less "
                      "and less, none from half the rounds on")
    more.add_argument("--dagger-epochs", type=int, metavar="N",
                      help="cloning's epochs over all the labels kept, after each DAgger round "
                      "(default 4)")
    more.add_argument("--dagger-student", metavar="sample|mean",
                      help="how the student acts on the steps it drives in the DAgger rounds: "
                      "sample its Gaussian (default) or take its mean, the action validation and "
                      "lgmd-sim eval execute")
    more.add_argument("--value-warmup", type=int, metavar="N",
                      help="after DAgger, N environment steps of PPO in which only the value "
                      "function learns, so that fine-tuning starts from advantages that mean "
                      "something (default 0: none; part of --steps); with --resume of a run "
                      "past its DAgger rounds that had none, it starts there")


def config_from_args(args: argparse.Namespace) -> Any:
    """The `TrainConfig` of ``train``'s arguments: those given, over the run's recorded
    options when resuming (where only `RESUMABLE` ones may differ), else the defaults."""
    from lgmd_sim.training.run import RESUMABLE, TrainConfig, resumable

    names = [f.name for f in dataclasses.fields(TrainConfig)]
    given = {k: getattr(args, k) for k in names if getattr(args, k, None) is not None}
    if args.resume is None:
        return TrainConfig(**given)
    # a run recorded before an option existed ran at its default
    recorded = {f.name: json.loads(json.dumps(f.default)) for f in dataclasses.fields(TrainConfig)
                if f.default is not dataclasses.MISSING} | resumable(args.resume)["config"]
    for key, value in given.items():
        if key not in RESUMABLE and json.loads(json.dumps(value)) != recorded[key]:
            raise ValueError(f"--{key.replace('_', '-')} {value} differs from the run being "
                             f"resumed ({recorded[key]}); only "
                             f"{', '.join('--' + k.replace('_', '-') for k in RESUMABLE)} "
                             "may change")
    if "hp" in given:
        shaped = [item for item in given["hp"] if item.partition("=")[0] == "policy_kwargs"]
        if shaped:
            raise ValueError(f"--hp {shaped[0]}: a resumed run keeps its network "
                             "(policy_kwargs); only other hyperparameters may be added")
        given["hp"] = [*recorded["hp"], *given["hp"]]  # added to the run's: a later one wins
    return TrainConfig(**{**{k: recorded[k] for k in names}, **given})


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.training.run import train
    from lgmd_sim.training.summary import summary_markdown

    if args.resume and args.out is not None and Path(args.out) != Path(args.resume):
        raise ValueError("--out and --resume name different folders: --resume continues "
                         "the run in its own folder")
    config = config_from_args(args)
    out = args.resume or args.out or f"train-{config.algo}-{config.obs}"
    result = train(config, out, resume=args.resume is not None,
                   progress=False if args.no_progress else None, command=args.command_line)
    return print_result(summary_markdown(result.path), result)
