"""`lgmd-sim record`: its arguments, then `lgmd_sim.apps.record.record`."""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import non_negative_float, non_negative_int, resolution


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "record", help="record a scenario's camera stream as a video; print its collision frame",
        description="Run one episode of SCENARIO (a name from `lgmd-sim envs`, e.g. "
        "HandheldApproach) with the carrier driving straight at cruise speed (towards the goal "
        "where there is one), write the camera stream to OUT and print the frame of first "
        "collision, the label `lgmd-sim detect --collision-frame` takes.",
    )
    p.add_argument("scenario", metavar="SCENARIO", help="scenario name, e.g. HandheldApproach")
    p.add_argument("out", metavar="OUT", help="video to write: .mkv or .avi (lossless FFV1) "
                   "or .mp4 (MPEG-4, lossy)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="episode seed (default 0)")
    p.add_argument("--jitter", type=non_negative_float, default=None,
                   help="jitter level (default: the scenario's)")
    p.add_argument("--resolution", type=resolution, default="paper",
                   help="paper (270x480, default), rl (120x160), small (64x64) or HxW")
    p.add_argument("--cruise", type=float, default=1.0,
                   help="forward action in [-1, 1], a fraction of the carrier's top speed "
                   "(default 1)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.apps.record import record

    overrides: dict[str, Any] = {"resolution": args.resolution}
    if args.jitter is not None:
        overrides["jitter"] = args.jitter
    rec = record(args.scenario, args.out, seed=args.seed, cruise=args.cruise,
                 progress=False if args.no_progress else None, **overrides)
    hit = (f"collision at frame {rec.collision_frame}" if rec.collision_frame is not None
           else "no collision")
    print(f"wrote {rec.path}: {rec.frames} frames at {rec.fps:g} fps, {hit}")
    if rec.collision_frame is not None:
        print(f"next: lgmd-sim detect {rec.path} --collision-frame {rec.collision_frame}")
    return 0
