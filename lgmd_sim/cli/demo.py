"""`lgmd-sim demo`: its arguments (and the defaults the README describes), then
`lgmd_sim.demo.run`."""

from __future__ import annotations

import argparse

from lgmd_sim.cli.args import non_negative_float, non_negative_int, resolution

#: The best detector of the calibration (its held-out objective, docs/results.md).
BEST = "feedback/calibrated-image"
#: An episode in which the best detector alarms before the collision; it does not in
#: every one (at seed 0 it stays silent): docs/results.md gives the rates.
SEED = 2
#: What the demo shows by default: the best detector, then the paper's model.
DETECTORS = (BEST, "feedback/paper")


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo", help="drive the robot at an obstacle over rough ground, LGMDs watching",
        description="One episode of RoughTerrainObstacles: the robot drives straight at an "
        "obstacle over rough ground while LGMD detectors watch its camera: by default the "
        "best detector of the calibration beside the paper's feedback LGMD. Writes "
        "an MP4 (camera view, the first detector's S layer, every membrane potential with "
        "the collision frame), a PNG summary and a still, and prints where they are.",
    )
    p.add_argument("--out", default="demo-out", metavar="DIR",
                   help="output folder (default: ./demo-out)")
    p.add_argument("--seed", type=non_negative_int, default=SEED,
                   help=f"episode seed (default {SEED})")
    p.add_argument("--jitter", type=non_negative_float, default=1.0,
                   help="terrain roughness on the common jitter scale (default 1.0)")
    p.add_argument("--models", default=",".join(DETECTORS), metavar="DETECTORS",
                   help="comma-separated detectors, MODEL[/PRESET][+FRONT END] (default "
                   f"{','.join(DETECTORS)}: the best detector, then the paper's model); "
                   "the first one's S layer is shown")
    p.add_argument("--resolution", type=resolution, default="paper",
                   help="camera resolution: paper (270x480, default), rl (120x160), small "
                   "(64x64) or HxW")


def run(args: argparse.Namespace) -> int:
    from lgmd_sim import demo, options

    return demo.run(out=args.out, seed=args.seed, jitter=args.jitter,
                    detectors=options.comma_list(args.models), resolution=args.resolution)
