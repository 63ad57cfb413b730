"""`python -m scripts.speed WHAT`: the maintainers' speed benchmarks, run from the checkout's
root; the arguments go by name to the `run` of `scripts.speed.WHAT`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from lgmd_sim.cli.args import positive_int, resolution


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m scripts.speed",
        description="Speed benchmarks (models, environments, front ends). They print figures "
        "and ratios measured in one run; run them on a quiet machine.",
    )
    speed = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    b = speed.add_parser(
        "models", help="frames/s per model, streaming and batched, vs a reference",
        description="Frames per second of every LGMD model on one core, streaming and "
        "batched, and the ratio to a straightforward per-equation reference implementation "
        "measured in the same run.",
    )
    _frame_size(b)
    b.add_argument("--frames", type=positive_int, default=300,
                   help="frames timed per run (default %(default)s)")
    b.add_argument("--streams", type=positive_int, default=8,
                   help="streams in batched mode (default %(default)s)")
    b.add_argument("--published", type=Path, metavar="FILE",
                   help="your copy of 'Harmonizing motion and contrast vision.py' (the "
                   "published Python LGMD, github.com/fuqinbing/harmonizing-motion-and-"
                   "contrast-vision-for-looming-detection): also time it against the feedback "
                   "LGMD on the same 240x432 frames (target: 200x)")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    b = speed.add_parser(
        "envs", help="environment steps/s per scenario vs bare renders of the same views",
        description="Environment steps per second per scenario at 120x160 and 270x480, the "
        "ratio to bare renders of the same views (each step's state rendered again, timed "
        "apart; target: 1.15x or less), and the speed-up of two async workers over one.",
    )
    b.add_argument("--steps", type=positive_int, default=200,
                   help="steps timed per run (default %(default)s)")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    b = speed.add_parser(
        "stabilize", help="ms per frame of each ego-motion front end, alone and per model",
        description="Milliseconds per frame, on one core, of the image-only rotation fit "
        "and the brightness gain alone, and of every model without a front end and with "
        "+pose (the warp of its stored maps), +image and +image+gain, on frames of a "
        "turning camera.",
    )
    _frame_size(b)
    b.add_argument("--frames", type=positive_int, default=60,
                   help="frames timed per run (default %(default)s)")
    b.add_argument("--markdown", action="store_true", help="print the tables as Markdown")
    b = speed.add_parser(
        "dataset", help="dataset generation frames/s vs the environment alone; disk per frame",
        description="Per scenario, in one run: frames per second of `dataset generate` "
        "against the same episodes run by the environment alone (same workers, size and "
        "seeds), and disk per frame of the stored frames against PNG and raw RGB.",
    )
    b.add_argument("--scenarios", default="all", help="comma-separated names, or all (default)")
    b.add_argument("--episodes", type=positive_int, default=6,
                   help="episodes per scenario (default %(default)s)")
    b.add_argument("--resolution", type=resolution, default="paper",
                   help="paper (270x480, default), rl, small or HxW")
    b.add_argument("--workers", type=positive_int, default=2,
                   help="worker processes (default %(default)s)")
    b.add_argument("--repeat", type=positive_int, default=2,
                   help="rounds of each measurement; the best counts (default %(default)s)")
    b.add_argument("--video", choices=("huffyuv", "ffv1", "mpeg4"), default="huffyuv",
                   help="frame storage: huffyuv (lossless, fast; default), ffv1 (lossless, "
                   "about half the size, slower to write), mpeg4 (lossy, small)")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    b = speed.add_parser(
        "closed-loop", help="env + LGMD + controller steps/s, the env's share; 2 workers vs 1",
        description="In one run: steps per second of the environment driven by "
        "ReactiveAvoid with each model, and the share of the time in the environment's "
        "step, timed apart on the same steps (target: 0.9 or more); frames per second of "
        "closed-loop benchmark episodes on one and on two workers (target: 1.85x or "
        "more), and of the environment alone stepping as many frames on one and on two "
        "workers: its own speed-up, the limit of the benchmark's, and the share of its two "
        "workers' speed the benchmark's reach (target: 0.9 or more).",
    )
    b.add_argument("--scenario", default="RoughTerrainObstacles",
                   help="scenario name (default %(default)s)")
    b.add_argument("--resolution", type=resolution, default="rl",
                   help="rl (120x160, default), paper, small or HxW")
    b.add_argument("--steps", type=positive_int, default=600,
                   help="steps timed per run (default %(default)s)")
    b.add_argument("--episodes", type=positive_int, default=24,
                   help="timed episodes per worker count (default %(default)s; each pool "
                   "is started and warmed before the timing)")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")

    b = speed.add_parser(
        "benchmark", help="the benchmark's episodes/s vs the closed-loop bench's; a row's cost",
        description="In one run, for ENTRY on the protocol's first seeds: episodes per "
        "second of `lgmd-sim bench closed-loop` and of `lgmd-sim benchmark` on the same "
        "goal and arena cells, on one and on two workers (target: the benchmark no "
        "slower), and the minutes one entry's row of the full protocol takes on two "
        "workers at that speed (target: 15 or less).",
    )
    b.add_argument("--entry", default="lgmd1/robot-image",
                   help="the entry timed (default %(default)s)")
    b.add_argument("--episodes", type=positive_int, default=4,
                   help="episodes per jitter level of each track (default %(default)s)")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")

    b = speed.add_parser(
        "train", help="training steps/s per algorithm vs the bare VecEnv (needs the rl extra)",
        description="In one run, per algorithm and observation (PPO on features and on "
        "privileged observations, SAC on features at three update rates): steps per second "
        "of stable-baselines3's learn() against the same training VecEnv alone (target: "
        "0.7 or more for PPO on 2 environments).",
    )
    b.add_argument("--env", default="lgmd_sim/RoughTerrainObstacles-v0", metavar="ID",
                   help="Gymnasium id of the environment (default %(default)s)")
    b.add_argument("--resolution", type=resolution, default="rl",
                   help="rl (120x160, default), paper, small or HxW")
    b.add_argument("--steps", type=positive_int, default=8192,
                   help="environment steps timed per row (default %(default)s)")
    b.add_argument("--envs", type=positive_int, default=2,
                   help="environments, one worker process each (default %(default)s)")
    b.add_argument("--markdown", action="store_true", help="print the table as Markdown")

    return p

def _frame_size(p: argparse.ArgumentParser) -> None:
    p.add_argument("--height", type=positive_int, default=270,
                   help="frame height in pixels (default %(default)s, the paper's)")
    p.add_argument("--width", type=positive_int, default=480,
                   help="frame width in pixels (default %(default)s, the paper's)")


def main(argv: list[str] | None = None) -> int:
    """The benchmark named by WHAT, with its options by name."""
    import inspect
    from importlib import import_module

    args = build_parser().parse_args(argv)
    job = import_module(f"scripts.speed.{args.what.replace('-', '_')}").run
    wanted = inspect.signature(job).parameters
    return job(**{k: v for k, v in vars(args).items() if k in wanted})


if __name__ == "__main__":
    sys.exit(main())
