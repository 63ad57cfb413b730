"""`lgmd-sim detect`: its arguments, and the `DetectConfig` made from them."""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import advanced, non_negative_float, non_negative_int


def fov_degrees(text: str) -> float:
    """A vertical field of view in degrees, 1 to 179."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 1.0 <= value <= 179.0:
        raise argparse.ArgumentTypeError(f"must be a number of degrees in [1, 179], got {text!r}")
    return value


def add(sub: argparse._SubParsersAction) -> None:
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
    p.add_argument(
        "--models", default="all",
        help="'all' (every model `lgmd-sim models` lists) or a comma-separated list of "
        "MODEL[/PRESET][+FRONT...]: a model name (`lgmd-sim models`) or a plug-in's "
        "'package.module:Class' spec, optionally with its preset and the front ends a "
        "video can have, +image and +gain (e.g. lgmd1/robot-image,feedback+gain; "
        "default: all)",
    )
    p.add_argument(
        "--preset", metavar="NAME",
        help="run each model listed without a preset at this one where it has it, e.g. "
        "calibrated (see `lgmd-sim models`); the others at their default. A model listed "
        "with another preset (MODEL/PRESET) is refused: give its preset once")
    p.add_argument(
        "--collision-frame", type=non_negative_int, metavar="N",
        help="labelled collision frame (0-based): marked in the figure, and used to score "
        "each model: a hit when its first alarm falls in the --window before this frame, "
        "this frame included (lead 0 s: an alarm with the collision, too late to act on), "
        "otherwise a miss (early, late or none), as `bench open-loop` and the published "
        "evaluation count it",
    )
    p.add_argument("--out", metavar="DIR",
                   help="write <name>.csv, <name>.json and <name>.png per video into DIR "
                   "(default: ./detect-out; with --json, files are written only when --out "
                   "is given). <name> is the video's stem, or its file name where two "
                   "videos share a stem")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object per video to stdout (with the membrane "
                   "potential of every frame)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    more = advanced(p, "the hit window, noise on the frames, and ego-motion compensation "
                    "(the camera's rotation, its brightness)")
    more.add_argument("--window", type=non_negative_float, default=1.0, metavar="S",
                      help="the hit window, seconds before the collision frame (default: "
                      "1.0)")
    more.add_argument("--noise", metavar="SPEC",
                      help="corrupt every frame before the models and the SSIM see it, as "
                      "the paper's noisy streams: comma-separated kind:level of gaussian "
                      "(variance on the [0, 1] scale, the paper's 0.001 to 0.009), saltpepper "
                      "(density, 0.001 to 0.009), shake (extra rotation, translation and "
                      "brightness gain, level 1: about 1 degree and 2 pixels), and a real "
                      "camera's: exposure (a smoothly drifting gain, level 1: about 10%%), "
                      "sensor (signal-dependent noise), blur (motion blur, level 1: about 3 "
                      "pixels) and jpeg (compression at quality 1 to 100), e.g. "
                      "gaussian:0.005,saltpepper:0.005; recorded in the JSON summary")
    more.add_argument("--noise-seed", type=non_negative_int, default=0, metavar="N",
                      help="seed of --noise (default: 0); frame t's noise depends only on "
                      "the seed, SPEC and t")
    more.add_argument("--stabilize", default="none", metavar="FRONT",
                      help="ego-motion compensation before every model: 'image' removes "
                      "the camera's rotation between frames, fitted from the frames alone (it "
                      "needs the camera's field of view, --fov); 'gain' removes brightness "
                      "changes between frames; 'image+gain' both (default: none); a model "
                      "listed with front ends of its own (+image) is refused with it. "
                      "Recorded per model in the JSON summary")
    more.add_argument("--fov", type=fov_degrees, default=55.0, metavar="DEG",
                      help="the camera's vertical field of view in degrees, for --stabilize "
                      "image (default: 55, the simulator's camera)")


def config_from_args(args: argparse.Namespace) -> Any:
    """The `DetectConfig` of ``detect``'s arguments; a dataset folder (or ``DIR:N``)
    among the videos becomes its episodes, each with its labelled collision frame."""
    from lgmd_sim.controllers import options
    from lgmd_sim.data import detect_inputs
    from lgmd_sim.detect import DetectConfig, Video

    return DetectConfig(
        videos=tuple(Video(*i) for i in detect_inputs(args.videos)),
        models=tuple(options.comma_list(args.models)), preset=args.preset,
        collision_frame=args.collision_frame, window=args.window, out=args.out,
        json_lines=args.json, noise=args.noise, noise_seed=args.noise_seed,
        stabilize=args.stabilize, fov=args.fov, progress=False if args.no_progress else None)


def run(args: argparse.Namespace) -> int:
    from lgmd_sim import detect

    return detect.run(config_from_args(args))
