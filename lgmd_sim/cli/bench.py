"""`lgmd-sim bench`: its arguments, and the typed configuration made from them.

The lists (scenarios, controllers, models, jitter levels) are parsed by
`lgmd_sim.controllers.options` and checked when the configuration is made, before any episode, so
that a bad one is a single error line naming it; the work is `lgmd_sim.benchmark`'s.
"""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import (
    add_closed_loop_options,
    add_detector_options,
    add_parallel_options,
    add_run_folder_options,
    advanced,
    non_negative_int,
    positive_int,
    print_result,
    resolution,
    run_options,
)
from lgmd_sim.controllers import options


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench", help="benchmark LGMD models in closed loop (driving) and open loop (clips)",
        description="The model benchmark: fair, reproducible tables and figures of how each "
        "LGMD model does, on the same seeds. (Code speed: `python -m scripts.speed`.)",
    )
    bench = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    b = bench.add_parser(
        "closed-loop", help="robots avoiding obstacles with each detector: collisions, "
        "successes, false alarms",
        description="Every cell (scenario x jitter level x controller x detector) runs the "
        "same episode seeds. Controllers: straight (no avoidance), oracle (the avoidance "
        "manoeuvre triggered by ground truth) and reactive (the manoeuvre triggered by an "
        "LGMD model's alarm, one cell per detector and side). Writes DIR/episodes.csv (one row per "
        "episode), DIR/summary.csv and summary.md (collision and success rates with 95% "
        "Wilson intervals, false alarms per minute, lead times; for roam tasks without a "
        "goal such as ArenaRoam, collisions per minute, the share of encounters avoided, "
        "the distance against the Oracle's and the time spent manoeuvring), figures and "
        "run.json.",
    )
    b.add_argument("--scenarios", default="RoughTerrainObstacles",
                   help="comma-separated scenario names (default RoughTerrainObstacles)")
    b.add_argument("--controllers", default="straight,oracle,reactive",
                   help="comma-separated controllers (default straight,oracle,reactive)")
    add_detector_options(b)
    more = advanced(b, "how the reactive controller tells the side, the episodes' first "
                    "seed, cruise speed and false-alarm horizon, the frame size, the "
                    "figures, and Ray")
    more.add_argument("--sides", default="halves",
                      help="comma-separated ways the reactive controller chooses the side to "
                      "turn away to, each a cell of its own: halves (one LGMD over the whole "
                      "view, the side from its S layer's left and right halves; the default) "
                      "or eyes (two LGMDs over overlapping left and right parts of the view, "
                      "turning away from the more excited one)")
    add_closed_loop_options(b, more, jitter="0,1,2")
    more.add_argument("--resolution", type=resolution, default="rl",
                      help="frame size: rl (120x160, default), paper (270x480), small or HxW")
    add_run_folder_options(b, "bench-closed-loop")
    add_parallel_options(b, more)

    b = bench.add_parser(
        "open-loop", help="the paper's Tables 2 and 3 in simulation: every model on the same "
        "recorded clips, with noise",
        description="Every model on the same clips: episodes of the scenarios (the carrier "
        "driving straight) or of a dataset (--dataset). The stationary clips (tripod scenarios "
        "at jitter 0) also run corrupted with Gaussian and salt-and-pepper noise at each "
        "--noise-levels value (the paper's dataset d). Per clip and model: ISI, MpSI, SI, "
        "first alarm, hit / miss / false alarm, lead time; per scenario, jitter, noise and "
        "model the same over the clips and the ROC AUC of the potential as a detector of an "
        "obstacle within --horizon seconds of collision. Writes summary.csv, summary.md, "
        "noise.md, a figure per scenario in the paper's layout, detection curves and the "
        "noise figure, and run.json.",
    )
    b.add_argument("--scenarios", default="all",
                   help="comma-separated scenario names, or all (default)")
    b.add_argument("--jitter", default="0,1", help="comma-separated jitter levels (default 0,1)")
    add_detector_options(b)
    b.add_argument("--seeds", type=positive_int, default=8, help="clips per scenario and "
                   "jitter level (default 8)")
    b.add_argument("--dataset", metavar="DIR", default=None,
                   help="take the clips from a dataset (DIR, or DIR:N for its episode N) "
                   "instead of simulating them")
    add_run_folder_options(b, "bench-open-loop")
    more = advanced(b, "the clips' first seed, noise levels and frame size, how a frame "
                    "or an alarm is scored, and Ray")
    more.add_argument("--first-seed", type=non_negative_int, default=0,
                      help="the first episode seed (default 0)")
    more.add_argument("--noise-levels", default="0.001,0.003,0.005,0.007,0.009",
                      help="Gaussian variances and salt-and-pepper densities for the "
                      "stationary clips (default 0.001,0.003,0.005,0.007,0.009; '' for none)")
    more.add_argument("--resolution", type=resolution, default="paper",
                      help="frame size of simulated clips: paper (270x480, default), rl, small "
                      "or HxW")
    more.add_argument("--horizon", type=float, default=1.0,
                      help="a frame counts as dangerous when an obstacle is within this time "
                      "to collision (s, default 1), for the ROC AUC")
    more.add_argument("--window", type=float, default=1.0,
                      help="a first alarm within this many seconds before the collision is a "
                      "hit (s, default 1)")
    add_parallel_options(b, more, "clips")


def closed_loop_config(args: argparse.Namespace) -> Any:
    """The `ClosedLoopConfig` of ``bench closed-loop``'s arguments."""
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    return ClosedLoopConfig(
        scenarios=tuple(options.comma_list(args.scenarios)),
        jitter=options.jitter_levels(args.jitter),
        controllers=tuple(options.comma_list(args.controllers)),
        detectors=options.detectors(args.models, args.presets), seeds=args.seeds,
        first_seed=args.first_seed, resolution=args.resolution, cruise=args.cruise,
        horizon=args.horizon, sides=tuple(options.comma_list(args.sides)),
        top_views=args.top_views)


def open_loop_config(args: argparse.Namespace) -> Any:
    """The `OpenLoopConfig` of ``bench open-loop``'s arguments."""
    from lgmd_sim.benchmark.open_loop import OpenLoopConfig

    return OpenLoopConfig(
        scenarios=tuple(options.comma_list(args.scenarios)), jitter=options.jitter_levels(
            args.jitter), seeds=args.seeds, first_seed=args.first_seed, dataset=args.dataset,
        detectors=options.detectors(args.models, args.presets),
        noise_levels=options.noise_levels(args.noise_levels), resolution=args.resolution,
        horizon=args.horizon, window=args.window)


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.benchmark import closed_loop, open_loop, summary

    job, config, markdown = (
        (closed_loop, closed_loop_config(args), summary.summary_markdown)
        if args.what == "closed-loop" else
        (open_loop, open_loop_config(args), open_loop.summary_markdown))
    result = job.run(config, args.out, run_options(args))
    return print_result(markdown(result.rows), result)
