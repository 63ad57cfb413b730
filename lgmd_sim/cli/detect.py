"""`lgmd-sim detect`: its arguments, and the `DetectConfig` made from them."""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import advanced, argtype, non_negative_float, non_negative_int, option
from lgmd_sim.core.configfile import doc


def add(sub: argparse._SubParsersAction) -> None:
    from lgmd_sim.detect.job import FOV, DetectConfig

    p = sub.add_parser(
        "detect",
        help="run LGMD models over videos or image folders; write CSV, JSON and a figure",
        description="Run LGMD models over every frame of each VIDEO (any file OpenCV can "
        "open, or a folder of images read in name order). Per video, writes into --out a "
        "per-frame CSV (membrane potential and alarm of each model, SSIM with the previous "
        "frame), a summary JSON and a PNG figure in the paper's style.",
    )
    p.add_argument("videos", nargs="+", metavar="VIDEO",
                   help="video file, image folder, or a dataset folder (DIR:N for its "
                   "episode N)")
    option(p, DetectConfig, "models", shown="all")
    option(p, DetectConfig, "preset", metavar="NAME", shown="none")
    option(p, DetectConfig, "collision_frame", type=non_negative_int, metavar="N",
           shown="none")
    option(p, DetectConfig, "out", metavar="DIR", shown="./detect-out; none with --json")
    p.add_argument("--json", action="store_true", help=doc(DetectConfig, "json_lines"))
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    more = advanced(p, "the hit window, noise on the frames, and ego-motion compensation "
                    "(the camera's rotation, its brightness)")
    option(more, DetectConfig, "window", type=non_negative_float, metavar="S")
    option(more, DetectConfig, "noise", metavar="SPEC", shown="none")
    option(more, DetectConfig, "noise_seed", type=non_negative_int, metavar="N")
    option(more, DetectConfig, "stabilize", metavar="FRONT")
    option(more, DetectConfig, "fov", type=argtype(float, FOV), metavar="DEG", shown="55")


def config_from_args(args: argparse.Namespace) -> Any:
    """The `DetectConfig` of ``detect``'s arguments; a dataset folder (or ``DIR:N``)
    among the videos becomes its episodes, each with its labelled collision frame."""
    from lgmd_sim.cli.args import configured, names
    from lgmd_sim.data import detect_inputs
    from lgmd_sim.detect import DetectConfig, Video

    return configured(DetectConfig, args, {
        "videos": tuple(Video(*i) for i in detect_inputs(args.videos)),
        "models": None if args.models is None else names(args.models), "preset": args.preset,
        "collision_frame": args.collision_frame, "window": args.window, "out": args.out,
        "json_lines": args.json or None, "noise": args.noise, "noise_seed": args.noise_seed,
        "stabilize": args.stabilize, "fov": args.fov,
        "progress": False if args.no_progress else None})


def run(args: argparse.Namespace) -> int:
    from lgmd_sim import detect

    return detect.run(config_from_args(args))
