"""`lgmd-sim demo`: its arguments (and the defaults the README describes), then
`lgmd_sim.apps.demo.run`."""

from __future__ import annotations

import argparse

from lgmd_sim.apps.defaults import AVOID_SEED, AVOIDER, DETECTORS, SEED
from lgmd_sim.cli.args import advanced, non_negative_float, non_negative_int, resolution


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo", help="drive the robot at an obstacle over rough ground, LGMDs watching",
        description="One episode of RoughTerrainObstacles: the robot drives straight at an "
        "obstacle over rough ground while LGMD detectors watch its camera: by default the "
        "feedback LGMD at its robot preset beside the paper's model. Writes "
        "an MP4 (camera view, the first detector's S layer, every membrane potential with "
        "the collision frame), a PNG summary and a still. Then one episode in which a "
        "detector (--avoider: LoomSteer on LGMD1 by default) drives the robot at the "
        "closed-loop benchmark's resolution and avoids the obstacles: an MP4 (camera view "
        "beside the path from above) and a PNG (the path with its alarms and manoeuvres, "
        "the membrane potential and the time to collision). All files are written, or (on "
        "an error) none; it prints where they are.",
    )
    p.add_argument("--out", default="demo-out", metavar="DIR",
                   help="output folder (default: ./demo-out)")
    p.add_argument("--seed", type=non_negative_int, default=SEED,
                   help=f"episode seed (default {SEED})")
    p.add_argument("--jitter", type=non_negative_float, default=1.0,
                   help="terrain roughness on the common jitter scale (default 1.0)")
    p.add_argument("--models", default=",".join(DETECTORS), metavar="DETECTORS",
                   help="comma-separated detectors, MODEL[/PRESET][+FRONT END] (default "
                   f"{','.join(DETECTORS)}: the robot preset, then the paper's model); "
                   "the first one's S layer is shown")
    p.add_argument("--no-avoid", action="store_true",
                   help="skip the avoiding episode (avoid.mp4, avoid.png: an earlier "
                   "run's in DIR are removed, so that the folder holds one set)")
    more = advanced(p, "the camera's resolution, and the avoiding episode's detector, seed "
                    "and resolution")
    more.add_argument("--resolution", type=resolution, default="rl",
                      help="camera resolution: rl (120x160, default: the robot presets' "
                      "calibration's), paper (270x480), small (64x64) or HxW")
    more.add_argument("--avoider", default=AVOIDER, metavar="DETECTOR[,HOW]",
                      help="the detector that drives the avoiding robot, and how: "
                      "ReactiveAvoid telling the threat's side by halves (of one LGMD's S "
                      "layer) or eyes (two LGMDs over the left and right of the view), or "
                      f"loom-steer (steering by two LGMDs' potentials) (default {AVOIDER})")
    more.add_argument("--avoid-seed", type=non_negative_int, default=AVOID_SEED,
                      help=f"seed of the avoiding episode (default {AVOID_SEED})")
    more.add_argument("--avoid-resolution", type=resolution, default=None,
                      help="camera resolution of the avoiding episode (default: the "
                      "closed-loop benchmark's, rl: its detectors' presets are calibrated "
                      "there)")


def episodes(args: argparse.Namespace) -> dict:
    """`lgmd_sim.apps.demo.run`'s arguments for the episodes (all but the output folder
    and the command line)."""
    from lgmd_sim.controllers import options

    return {"seed": args.seed, "jitter": args.jitter,
            "detectors": options.comma_list(args.models), "resolution": args.resolution,
            "avoider": None if args.no_avoid else args.avoider,
            "avoid_seed": args.avoid_seed, "avoid_resolution": args.avoid_resolution}


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.apps import demo

    return demo.run(out=args.out, command=getattr(args, "command_line", None),
                    **episodes(args))
