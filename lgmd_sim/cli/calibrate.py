"""`lgmd-sim calibrate`: its arguments, and the `CalibrateConfig` made from them."""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import (
    add_config_file,
    add_parallel_options,
    add_run_folder_options,
    advanced,
    configured,
    names,
    non_negative_int,
    option,
    positive_int,
    print_result,
    resolution,
    run_options,
)
from lgmd_sim.core.configfile import doc


def add(sub: argparse._SubParsersAction) -> None:
    from lgmd_sim.calibration.run import CalibrateConfig

    p = sub.add_parser(
        "calibrate", help="tune every model by the same search on recorded clips; validate "
        "on held-out seeds; write calibrated presets",
        description="Record the task's clips (walker: jitter approaches, stationary "
        "approaches, near misses; robot: the robot driving at obstacles and where none is "
        "in its way) with search seeds and held-out seeds; evaluate BUDGET candidate "
        "settings of every detector (the feedback LGMD, its open-loop control, each "
        "baseline) on the search "
        "clips; choose each detector's best setting and threshold by the task's declared "
        "objective (walker: lgmd_sim.calibration.objective and "
        "docs/experiments/results-log.md's section \"Calibration\"; robot: "
        "lgmd_sim.calibration.robot and docs/experiments/results-log.md's section "
        "\"The robot: its own calibration, two eyes, two tasks\") and report it on the "
        "held-out clips. Writes DIR/summary.md, "
        "DIR/calibration.png and DIR/calibrated.json (the presets, with the command, seeds "
        "and objective); --save-presets merges them into your presets file, which makes "
        "them the models' `calibrated` presets (robot task: `robot`; video task: `video`) "
        "on top of the shipped ones.",
    )
    option(p, CalibrateConfig, "task")
    option(p, CalibrateConfig, "detectors", type=names, shown="all")
    option(p, CalibrateConfig, "budget", type=positive_int)
    option(p, CalibrateConfig, "seeds", type=positive_int)
    p.add_argument("--save-presets", nargs="?", const=True, default=None, metavar="PATH",
                   help=f"{doc(CalibrateConfig, 'save_presets')}; with PATH, into that file "
                   "instead: " + doc(CalibrateConfig, "presets_file"))
    add_config_file(p, "heldout_seed, seed", CalibrateConfig)
    add_run_folder_options(p, "calibration")
    add_parallel_options(p, "clips and candidates")
    more = advanced(p, "the search clips' first seed, and the clips' frame size")
    option(more, CalibrateConfig, "first_seed", type=non_negative_int)
    option(more, CalibrateConfig, "resolution", type=resolution)


def config_from_args(args: argparse.Namespace) -> Any:
    """The `CalibrateConfig` of ``calibrate``'s arguments."""
    from lgmd_sim.calibration.run import CalibrateConfig

    saved = args.save_presets
    return configured(CalibrateConfig, args, {
        "task": args.task, "detectors": None if args.detectors == ("all",) else args.detectors,
        "budget": args.budget, "seeds": args.seeds, "first_seed": args.first_seed,
        "resolution": args.resolution, "save_presets": saved is True or None,
        "presets_file": saved if isinstance(saved, str) else None})


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.calibration.report import summary_markdown
    from lgmd_sim.calibration.run import calibrate
    from lgmd_sim.calibration.tasks import TASKS

    config = config_from_args(args)
    result = calibrate(config, args.out, run_options(args))
    return print_result(summary_markdown(result.rows, TASKS[config.task].objective), result)
