"""`lgmd-sim calibrate`: its arguments, and the `CalibrateConfig` made from them."""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import (
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
    p.add_argument("--task", default="walker",
                   help="walker (default): the clips of a hand-held, mutual or steady "
                   "camera and near misses, a hit when the first alarm comes in the last "
                   "15%% of an approach; presets calibrated, calibrated-image ... robot: "
                   "the robot driving straight over rough ground (jitter 0, 1, 2) at "
                   "obstacles and where none is in its way, a hit when the first alarm "
                   "comes in the avoidance manoeuvre's window and silence while no obstacle "
                   "is within 2 s (lgmd_sim.calibration.robot); presets robot, robot-imu, "
                   "robot-image ... robot-frames: the same, an alarm being 4 rising frames "
                   "above the threshold (the video presets' rule); presets robot-frames, "
                   "robot-frames-image ... video: for footage from a camera nobody calibrated, the "
                   "walker's clips and synthetic stimuli that do not loom (receding, "
                   "crossing, gratings, flicker: a hit when silent), every clip with a real "
                   "camera's noise and the scenes' cameras of 40 to 90 degrees, every "
                   "detector with the front end +image+gain (lgmd_sim.calibration.objective."
                   "VIDEO); presets video ...")
    p.add_argument("--detectors", default="all",
                   help="comma-separated among feedback, feedback-open-loop, lgmd1, lgmd2, "
                   "f_on, f_off, any other model whose class declares a search_space (a "
                   "registered name or a package.module:Class spec), each also with a "
                   "front end (+image: the rotation fitted from the frames; +imu: the "
                   "world's IMU; the video task's: +image+gain, given or not), or all "
                   "(default: every model available that declares one)")
    p.add_argument("--budget", type=positive_int, default=32,
                   help="candidate settings per detector, its starting preset included "
                   "(default 32, the same for every detector)")
    p.add_argument("--seeds", type=positive_int, default=8,
                   help="episode seeds per clip group in each set (default 8)")
    p.add_argument("--save-presets", action="store_true",
                   help="also merge the calibrated presets into your presets file, "
                   "calibrated.json in $LGMD_SIM_DATA_DIR (default: the user data folder, "
                   "~/.local/share/lgmd-sim on Linux); only the calibrated detectors' "
                   "presets change there, and the models read it on top of the shipped "
                   "presets")
    add_run_folder_options(p, "calibration")
    more = advanced(p, "the search's and the held-out clips' seeds, the clips' frame size, "
                    "another presets file, and Ray")
    more.add_argument("--first-seed", type=non_negative_int, default=0,
                      help="first search seed (default 0)")
    more.add_argument("--heldout-seed", type=non_negative_int, default=100,
                      help="first held-out seed (default 100)")
    more.add_argument("--seed", type=non_negative_int, default=0,
                      help="seed of the random search (default 0)")
    more.add_argument("--resolution", type=resolution, default="rl",
                      help="frame size of the clips: rl (120x160, default: the size of the "
                      "closed-loop task), paper, small or HxW")
    more.add_argument("--presets-file", metavar="PATH", default=None,
                      help="merge the calibrated presets into PATH instead of your presets "
                      "file (implies --save-presets); the models read only your presets "
                      "file (calibrated.json in $LGMD_SIM_DATA_DIR, else in the user data "
                      "folder), so a PATH named calibrated.json serves them once "
                      "LGMD_SIM_DATA_DIR names its folder. Either file is checked before the "
                      "calibration starts: a presets file or none yet, writable, in a folder "
                      "that can be written or made")
    add_parallel_options(p, more, "clips and candidates")


def config_from_args(args: argparse.Namespace) -> Any:
    """The `CalibrateConfig` of ``calibrate``'s arguments."""
    from lgmd_sim.calibration.run import CalibrateConfig

    return CalibrateConfig(
        task=args.task, detectors=tuple(options.comma_list(args.detectors)), budget=args.budget,
        seeds=args.seeds, first_seed=args.first_seed, heldout_seed=args.heldout_seed,
        seed=args.seed, resolution=args.resolution, save_presets=args.save_presets,
        presets_file=args.presets_file)


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.calibration.report import summary_markdown
    from lgmd_sim.calibration.run import calibrate
    from lgmd_sim.calibration.tasks import TASKS

    config = config_from_args(args)
    result = calibrate(config, args.out, run_options(args))
    return print_result(summary_markdown(result.rows, TASKS[config.task].objective), result)
