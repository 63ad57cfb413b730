"""`lgmd-sim demo`: its command-line arguments (the implementation loads when it runs)."""

from __future__ import annotations

import argparse

from lgmd_sim.cli.args import non_negative_float, non_negative_int


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo", help="drive the robot at an obstacle over rough ground, with the feedback LGMD",
        description="One episode of RoughTerrainObstacles: the robot drives straight at an "
        "obstacle over rough ground while the feedback LGMD watches its camera. Writes an MP4 "
        "(camera view, the LGMD's S layer, the membrane potential with the collision frame) "
        "and a PNG summary, and prints where they are.",
    )
    p.add_argument("--out", default="demo-out", metavar="DIR",
                   help="output folder (default: ./demo-out)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="episode seed (default 0)")
    p.add_argument("--jitter", type=non_negative_float, default=1.0,
                   help="terrain roughness on the common jitter scale (default 1.0)")
    p.add_argument("--model", default="feedback", help="LGMD model to run (default feedback)")
    p.set_defaults(run="lgmd_sim.demo:run")
