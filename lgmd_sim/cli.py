"""The `lgmd-sim` command: one entry point, one subcommand per job.

Each subcommand's implementation is imported only when it runs, so `--help` stays fast
and `lgmd-sim detect` never loads MuJoCo. Errors a user can fix (a bad file, an unknown
model, a bad value) print one line naming the thing and exit with status 2.
"""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Sequence
from importlib import import_module

from lgmd_sim import __version__
from lgmd_sim.extras import MissingExtra


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text}")
    return value


def _non_negative_float(text: str) -> float:
    value = float(text)
    if not value >= 0:  # also rejects NaN
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text}")
    return value


def _resolution(text: str) -> str | list[int]:
    """A named frame size (paper, rl, small) or HEIGHTxWIDTH."""
    from lgmd_sim.world.params import RESOLUTIONS, resolution_check

    if text in RESOLUTIONS:
        return text
    try:
        size = [int(v) for v in text.lower().split("x")]
    except ValueError:
        size = []
    if len(size) != 2 or resolution_check(size):
        raise argparse.ArgumentTypeError(
            f"must be {', '.join(RESOLUTIONS)} or HEIGHTxWIDTH (e.g. 270x480), got {text!r}")
    return size


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="lgmd-sim",
        description="A jitter-robot testbed for bio-inspired (LGMD) collision detection: "
        "LGMD models, a MuJoCo jitter world with Gymnasium environments, and tools to run "
        "the models on your own video.",
    )
    parser.add_argument("--version", action="version", version=f"lgmd-sim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser(
        "detect",
        help="run LGMD models over videos or image folders; write CSV, JSON and a figure",
        description="Run LGMD models over every frame of each VIDEO (any file OpenCV can "
        "open, or a folder of images read in name order). Per video, writes into --out a "
        "per-frame CSV (membrane potential and alarm of each model, SSIM with the previous "
        "frame), a summary JSON and a PNG figure in the paper's style.",
    )
    p.add_argument("videos", nargs="+", metavar="VIDEO", help="video file or image folder")
    p.add_argument(
        "--models", default="all",
        help="'all' or a comma-separated list of: feedback, lgmd1, lgmd2, f_on, f_off "
        "(default: all)",
    )
    p.add_argument(
        "--collision-frame", type=_non_negative_int, metavar="N",
        help="labelled collision frame (0-based): marked in the figure, and used to score "
        "hit, miss and lead time",
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
    p.set_defaults(run="lgmd_sim.detect:run")

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
    p.add_argument("--seed", type=_non_negative_int, default=0, help="episode seed (default 0)")
    p.add_argument("--jitter", type=_non_negative_float, default=None,
                   help="jitter level (default: the scenario's)")
    p.add_argument("--resolution", type=_resolution, default="paper",
                   help="paper (270x480, default), rl (120x160), small (64x64) or HxW")
    p.add_argument("--cruise", type=float, default=1.0,
                   help="forward action in [-1, 1], a fraction of the carrier's top speed "
                   "(default 1)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(run="lgmd_sim.record:run")

    p = sub.add_parser(
        "models", help="list the LGMD models and their parameters with sources",
        description="List the LGMD models, their presets and every parameter with its "
        "default and where that default comes from.",
    )
    p.add_argument("name", nargs="?", help="show one model only")
    p.set_defaults(run="lgmd_sim.cli:list_models")

    p = sub.add_parser(
        "envs", help="list the registered scenarios and their parameters",
        description="List the Gymnasium scenarios (lgmd_sim/<Name>-v0) of the catalogue in "
        "envs/, with their parameters and defaults.",
    )
    p.add_argument("name", nargs="?", help="show one scenario only")
    p.set_defaults(run="lgmd_sim.envs.catalogue:run_list")

    p = sub.add_parser(
        "demo", help="drive the robot at an obstacle over rough ground, with the feedback LGMD",
        description="One episode of RoughTerrainObstacles: the robot drives straight at an "
        "obstacle over rough ground while the feedback LGMD watches its camera. Writes an MP4 "
        "(camera view, the LGMD's S layer, the membrane potential with the collision frame) "
        "and a PNG summary, and prints where they are.",
    )
    p.add_argument("--out", default="demo-out", metavar="DIR",
                   help="output folder (default: ./demo-out)")
    p.add_argument("--seed", type=_non_negative_int, default=0, help="episode seed (default 0)")
    p.add_argument("--jitter", type=_non_negative_float, default=1.0,
                   help="terrain roughness on the common jitter scale (default 1.0)")
    p.add_argument("--model", default="feedback", help="LGMD model to run (default feedback)")
    p.set_defaults(run="lgmd_sim.demo:run")

    p = sub.add_parser(
        "speed", help="speed benchmarks (models, environments); print tables",
        description="Speed benchmarks. They print figures and ratios measured in one run; "
        "run them on a quiet machine.",
    )
    speed = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    b = speed.add_parser(
        "models", help="frames/s per model, streaming and batched, vs a reference",
        description="Frames per second of every LGMD model on one core, streaming and "
        "batched, and the ratio to a straightforward per-equation reference implementation "
        "measured in the same run.",
    )
    b.add_argument("--height", type=_positive_int, default=270)
    b.add_argument("--width", type=_positive_int, default=480)
    b.add_argument("--frames", type=_positive_int, default=300, help="frames timed per run")
    b.add_argument("--streams", type=_positive_int, default=8, help="streams in batched mode")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    b.set_defaults(run="lgmd_sim.speed.models:run")
    b = speed.add_parser(
        "envs", help="environment steps/s per scenario vs a bare render loop",
        description="Environment steps per second per scenario at 120x160 and 270x480, the "
        "ratio to a bare render loop of the same scene, and the speed-up of two async "
        "workers over one.",
    )
    b.add_argument("--steps", type=_positive_int, default=200, help="steps timed per run")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    b.set_defaults(run="lgmd_sim.speed.envs:run")
    return parser


def list_models(args: argparse.Namespace) -> int:
    """`lgmd-sim models`: every model, its presets and parameters with their sources."""
    from lgmd_sim import models

    names = [args.name] if args.name else models.available()
    for name in names:
        cls = models.model_class(name)
        print(f"{name}: {cls.__doc__.strip().splitlines()[0]}")
        print(f"  presets: {', '.join(cls.presets)} (default {next(iter(cls.presets))})")
        for pname, default, source, _doc in cls.Params.describe():
            print(f"  {pname} = {default!r}  [{source}]")
        print()
    return 0


class Terminated(BaseException):
    """SIGTERM, raised where the program is so that cleanup (partial files) runs."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    module, func = args.run.split(":")
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        return int(getattr(import_module(module), func)(args) or 0)
    except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
        return 0
    except (ValueError, OSError, MissingExtra) as exc:  # a user's input: say what, briefly
        print(f"lgmd-sim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"lgmd-sim {args.command}: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except Terminated:
        print(f"lgmd-sim {args.command}: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    finally:
        signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
