"""A closed-loop benchmark run as Ray tasks: on this machine (a Ray instance started for
the run) or on a running Ray cluster, with the same results as a local run.

Every job that keeps a run folder takes `ray_address` ("local", "auto" or "HOST:PORT";
the commands' `--workers ray`, with the RAY_ADDRESS variable or without it for "local"):
each episode is then a Ray task, and an episode depends only on its cell and seed, so the
tables are the same wherever it ran (docs/guides/scaling.md). This example's own `--ray`
option gives the address. Needs the `ray` extra.

    python examples/ray_benchmark.py --out runs/ray-example --compare

Writes OUT/ray (the run folder: summary.md, summary.csv, episodes.csv, figures) and, with
--compare, OUT/local, the same benchmark in this process, checked to give the same rows.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig, run
from lgmd_sim.benchmark.summary import summary_markdown
from lgmd_sim.cli.args import error_line
from lgmd_sim.core.extras import MissingExtra
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.detect.outputs import check_out_folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("ray-example"),
                        help="output folder (default ./ray-example)")
    parser.add_argument("--ray", default="local", metavar="ADDRESS",
                        help="'local' starts Ray here for the run (default); 'auto' or "
                        "HOST:PORT joins a running cluster")
    parser.add_argument("--seeds", type=int, default=2,
                        help="episodes per controller (default 2)")
    parser.add_argument("--compare", action="store_true",
                        help="run the same benchmark in this process too, and check that "
                        "its rows are the Ray run's")
    args = parser.parse_args()
    try:
        benchmark(args.out, args.ray, args.seeds, args.compare)
    except (ValueError, OSError, MissingExtra) as exc:  # as lgmd-sim: one line, status 2
        parser.exit(2, f"{parser.prog}: error: {error_line(exc, parser, args)}\n")


def benchmark(out: Path, ray: str, seeds: int, compare: bool) -> None:
    """Run the benchmark on Ray into OUT/ray and, with `compare`, in this process into
    OUT/local, checking that both give the same rows."""
    check_out_folder(out)
    # The robot driving at a box over rough ground (jitter 1), 64 x 64 frames: Straight,
    # the Oracle and ReactiveAvoid on the LGMD1 at its robot preset with the image front
    # end, one cell each.
    config = ClosedLoopConfig(scenarios=("RobotApproach",), jitter=(1.0,),
                              controllers=("straight", "oracle", "reactive"),
                              detectors=(("lgmd1", "robot-image"),), seeds=seeds,
                              resolution="small")
    # resume=True: running the same command again completes an interrupted run
    on_ray = run(config, out / "ray", RunOptions(ray_address=ray, resume=True, progress=False))
    print(summary_markdown(on_ray.rows))
    if compare:
        here = run(config, out / "local", RunOptions(workers=1, resume=True, progress=False))
        if here.rows != on_ray.rows:
            sys.exit("the local run's rows differ from the Ray run's")
        print(f"the same {len(here.rows)} rows in this process as on Ray")


if __name__ == "__main__":
    main()
