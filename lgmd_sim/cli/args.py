"""What the subcommands share: argument types that reject a bad value with a clear message,
the "advanced" group that --help lists after the options a user needs first, the option
groups of the run-folder, parallel and detector options, and the keyword arguments and
printout of a job that keeps a run folder."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from lgmd_sim.envs.zone import CRUISE, FALSE_ALARM_HORIZON

if TYPE_CHECKING:
    from lgmd_sim.core.parallel import RunOptions

#: What an option helper adds its arguments to: a parser, or one of its groups.
Options = argparse._ActionsContainer


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text}")
    return value


def non_negative_float(text: str) -> float:
    value = float(text)
    if not value >= 0:  # also rejects NaN
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text}")
    return value


def resolution(text: str) -> str | tuple[int, int]:
    """A named frame size (paper, rl, small) or HEIGHTxWIDTH, as the Python API takes it
    (`lgmd_sim.world.params.parse_resolution`)."""
    from lgmd_sim.world.params import parse_resolution

    try:
        return parse_resolution(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def advanced(p: argparse.ArgumentParser, about: str) -> argparse._ArgumentGroup:
    """`p`'s research and tuning options: --help lists them under "advanced", after the
    options a user needs first, with `about` saying what they are for. Where an option is
    listed changes nothing of how it parses."""
    return p.add_argument_group("advanced", about)


def add_parallel_options(p: Options, more: Options, unit: str = "episodes") -> None:
    """--workers and --no-progress in `p`, --ray in `more` (a cluster is not where one
    starts): how a command's independent jobs run."""
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes (default: every core)")
    more.add_argument("--ray", metavar="ADDRESS", default=None,
                      help=f"run the {unit} as Ray tasks: 'local' starts Ray here, 'auto' or "
                      "HOST:PORT joins a cluster (needs the ray extra)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def add_run_folder_options(p: Options, default: str) -> None:
    """--out and --resume of a command that keeps its results in a run folder."""
    p.add_argument("--out", default=default, metavar="DIR",
                   help=f"output folder (default ./{default})")
    p.add_argument("--resume", action="store_true",
                   help="complete the run in DIR (same configuration): finished jobs are "
                   "kept")


def run_options(args: argparse.Namespace) -> RunOptions:
    """How a job given the options of `add_parallel_options` (and `add_run_folder_options`,
    where it has them) runs, checked before it starts."""
    from lgmd_sim.core.parallel import RunOptions

    return RunOptions(workers=args.workers, ray_address=args.ray,
                      progress=False if args.no_progress else None,
                      resume=getattr(args, "resume", False), command=args.command_line)


def print_result(table: str, result: Any) -> int:
    """A job's summary table, then the files it wrote (a `lgmd_sim.core.runs.RunResult`)."""
    print(table, end="")
    print(f"wrote {result.path}/: {', '.join(result.files)}")
    return 0


def add_detector_options(p: Options, default: str | None = "all",
                         means: str = "all, each at its default preset") -> None:
    """--models and --presets: the detectors a benchmark compares (--models `default`,
    which `means` what the help says)."""
    p.add_argument("--models", default=default,
                   help="'all' or a comma-separated list of MODEL or MODEL/PRESET, each "
                   f"optionally with front ends (e.g. lgmd1/calibrated+image); default {means}")
    p.add_argument("--presets", default=None,
                   help="comma-separated presets: each model listed without a preset runs "
                   "each of these it has (its default when it has none of them)")


def add_closed_loop_options(p: Options, more: Options, jitter: str, seeds: int = 50,
                            top_views: int = 1) -> None:
    """The closed-loop benchmark's episodes (`lgmd-sim bench closed-loop`, `lgmd-sim
    eval`): --jitter (default `jitter`) and --seeds (default `seeds`) in `p`; --first-seed,
    --cruise, --horizon and --top-views (default `top_views`) in `more`."""
    p.add_argument("--jitter", default=jitter,
                   help=f"comma-separated jitter levels (default {jitter})")
    p.add_argument("--seeds", type=positive_int, default=seeds,
                   help=f"episodes per cell (default {seeds})")
    more.add_argument("--first-seed", type=non_negative_int, default=1000,
                      help="the first episode seed; seeds are consecutive (default 1000: "
                      "never a training or validation seed of `lgmd-sim train`)")
    more.add_argument("--cruise", type=float, default=CRUISE,
                      help="forward action of every controller while cruising (default 0.6)")
    more.add_argument("--horizon", type=float, default=FALSE_ALARM_HORIZON,
                      help="an alarm is false when no obstacle is within this time to "
                      "collision (s, default %(default)s)")
    more.add_argument("--top-views", type=positive_int, default=top_views,
                      help="how many of the seeds, the first ones, trajectories.png draws "
                      f"from above, a row of panels each (default {top_views})")
