"""The `lgmd-sim` command: one entry point, one subcommand per job.

Each subcommand is a module of this package (``lgmd_sim.cli.<command>``) with two
functions: ``add(subparsers)`` declares its arguments, and ``run(args)`` makes the job's
typed configuration from them (``config_from_args``-style functions, checked when the
configuration is made) and calls the job's package, which does the work and never sees
an argparse namespace. The job's code is imported only when it runs, so `--help` stays
fast and `lgmd-sim detect` never loads MuJoCo. Errors a user can fix (a bad file, an
unknown model, a bad value) print one line naming the thing and exit with status 2.
"""

from __future__ import annotations

import argparse
import os
import shlex
import signal
import sys
from collections.abc import Sequence
from importlib import import_module

from lgmd_sim import __version__
from lgmd_sim.cli.args import error_line
from lgmd_sim.core import numerics
from lgmd_sim.core.extras import MissingExtra
from lgmd_sim.core.jobs import WorkerDied
from lgmd_sim.core.stops import catch_swallowed_stops, stop_raised

#: The subcommands, in the order `--help` lists them.
COMMANDS = ("demo", "detect", "record", "models", "envs", "bench", "calibrate", "dataset",
            "train", "benchmark", "leaderboard", "verify")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="lgmd-sim",
        description="A jitter-robot testbed for bio-inspired (LGMD) collision detection: "
        "LGMD models, a MuJoCo jitter world with Gymnasium environments, and tools to run "
        "the models on your own video.",
    )
    parser.add_argument("--version", action="version", version=f"lgmd-sim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        import_module(f"lgmd_sim.cli.{command}").add(sub)
    return parser


class Terminated(BaseException):
    """SIGTERM, raised where the program is so that cleanup (partial files) runs."""


def _terminate(signum: int, frame: object) -> None:
    stop_raised()
    raise Terminated


def _interrupt(signum: int, frame: object) -> None:
    stop_raised()
    raise KeyboardInterrupt


def command_line(argv: Sequence[str]) -> str:
    """What a run's records say was run: the command, with the PYTHONPATH it ran under
    (where a plug-in's module comes from), so that the line reruns it."""
    path = os.environ.get("PYTHONPATH")
    return (f"PYTHONPATH={shlex.quote(path)} " if path else "") + shlex.join(
        ["lgmd-sim", *argv])


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    args.command_line = command_line(argv)
    previous = signal.signal(signal.SIGTERM, _terminate)
    # Ctrl-C as Python's default raises it (where it is ignored, as in a background job, it
    # stays ignored), noted as a stop
    previous_int = signal.getsignal(signal.SIGINT)
    if previous_int is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupt)
    previous_hook = catch_swallowed_stops({Terminated: signal.SIGTERM,
                                           KeyboardInterrupt: signal.SIGINT})
    try:
        numerics.wanted()  # a bad LGMD_SIM_NUMERICS, taken for the default at import
        return int(import_module(f"lgmd_sim.cli.{args.command}").run(args) or 0)
    except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
        return 0
    except (ValueError, OSError, MissingExtra) as exc:  # a user's input: say what, briefly
        print(f"lgmd-sim {args.command}: error: {error_line(exc, parser, args)}",
              file=sys.stderr)
        return 2
    except WorkerDied as exc:  # killed, or out of memory: the finished jobs are kept
        resume = ("; the finished ones are kept: run the same command with --resume to "
                  "complete it" if hasattr(args, "resume") else "")
        print(f"lgmd-sim {args.command}: error: {exc}{resume}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"lgmd-sim {args.command}: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except Terminated:
        print(f"lgmd-sim {args.command}: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    finally:
        signal.signal(signal.SIGTERM, previous)
        if previous_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, previous_int)
        sys.unraisablehook = previous_hook
