"""`lgmd-sim bench`: its arguments, and the typed configuration made from them.

Each option is a field of the job's configuration (`ClosedLoopConfig`, `OpenLoopConfig`;
trained policies: `lgmd_sim.training.evaluate.EvalConfig`), its help the field's own
(`lgmd_sim.cli.args.option`); the research fields are keys of a --config file. Lists are
parsed by `lgmd_sim.controllers.options` and every value is checked when the
configuration is made, before any episode, so that a bad one is a single error line
naming it; the work is `lgmd_sim.benchmark`'s.
"""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import (
    add_config_file,
    add_detector_options,
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
from lgmd_sim.controllers import options
from lgmd_sim.core.extras import install_command


def add(sub: argparse._SubParsersAction) -> None:
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
    from lgmd_sim.benchmark.open_loop import OpenLoopConfig
    from lgmd_sim.training.evaluate import EvalConfig

    p = sub.add_parser(
        "bench", help="benchmark LGMD models and trained policies in closed loop (driving) "
        "and open loop (clips)",
        description="The model benchmark: fair, reproducible tables and figures of how each "
        "LGMD model does, on the same seeds. (Code speed: `python -m scripts.speed`.)",
    )
    bench = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    b = bench.add_parser(
        "closed-loop", help="robots avoiding obstacles with each detector or trained policy: "
        "collisions, successes, false alarms",
        description="Every cell (scenario x jitter level x controller x detector) runs the "
        "same episode seeds. Writes DIR/episodes.csv (one row per episode), DIR/summary.csv "
        "and summary.md (collision and success rates with 95% Wilson intervals, false alarms "
        "per minute, lead times; for roam tasks without a goal such as ArenaRoam, collisions "
        "per minute, the share of encounters avoided, the distance against the Oracle's and "
        "the time spent manoeuvring), figures and run.json. With --policies, each trained "
        "policy is a controller of its own beside the others, every cell in the environment "
        "the policies were trained in, and DIR/eval.md adds the distance travelled (needs "
        f"the rl extra: install it {install_command('rl')}). Trust: a policy folder is "
        "policy.json and policy.npz, the network's weights as plain arrays, loaded without "
        "unpickling, so evaluating a policy from anyone runs none of its author's code: its "
        "policy.json may name a built-in, registered or installed model, and a plug-in's "
        "spec (code) only where --models names it too. stable-baselines3's own files are "
        "pickles, which run whatever their author put in them: `lgmd-sim train --resume "
        "DIR` loads DIR/checkpoints/ and `python -m lgmd_sim.policies.convert DIR` an older "
        "folder's policy.zip; use those only on files you made or from someone you trust.",
    )
    option(b, ClosedLoopConfig, "scenarios", type=names)
    b.add_argument("--controllers", default=None,
                   help="comma-separated controllers: straight (no avoidance), oracle (the "
                   "avoidance manoeuvre triggered by ground truth), reactive (the manoeuvre "
                   "triggered by an LGMD model's alarm, a cell per detector and side), a "
                   "plug-in's package.module:Class, or none beside --policies (default "
                   "straight,oracle,reactive)")
    add_detector_options(b, default=None, means="all, each at its default preset (with "
                         "--policies: the models the policies observe, at their presets)")
    b.add_argument("--policies", type=names, metavar="POLICY,...", default=None,
                   help="trained policies as controllers of their own: folders (policy.json "
                   "and policy.npz, as lgmd-sim train writes them) or shipped names (shipped: "
                   "the default policy); their defaults are those of the evaluation a "
                   "shipped policy's POLICY.md quotes")
    # --policies makes an EvalConfig: its defaults are those of the evaluation a shipped
    # policy's POLICY.md quotes
    option(b, ClosedLoopConfig, "jitter", beside=("--policies", EvalConfig))
    option(b, ClosedLoopConfig, "seeds", type=positive_int, beside=("--policies", EvalConfig))
    add_config_file(b, "cruise, horizon, sides, top_views (with --policies, EvalConfig's: "
                    "cruise, horizon, top_views)", ClosedLoopConfig, EvalConfig)
    add_run_folder_options(b, "bench-closed-loop")
    add_parallel_options(b)
    more = advanced(b, "the episodes' first seed and frame size")
    option(more, ClosedLoopConfig, "first_seed", type=non_negative_int)
    option(more, ClosedLoopConfig, "resolution", type=resolution)

    b = bench.add_parser(
        "open-loop", help="the paper's Tables 2 and 3 in simulation: every model on the same "
        "recorded clips, with noise",
        description="Every model on the same clips: episodes of the scenarios (the carrier "
        "driving straight) or of a dataset (--dataset). The stationary clips (tripod scenarios "
        "at jitter 0) also run corrupted with Gaussian and salt-and-pepper noise at each "
        "noise level (the paper's dataset d). Per clip and model: ISI, MpSI, SI, first "
        "alarm, hit / miss / false alarm, lead time; per scenario, jitter, noise and model "
        "the same over the clips and the ROC AUC of the potential as a detector of an "
        "obstacle within the horizon of collision. Writes summary.csv, summary.md, "
        "noise.md, a figure per scenario in the paper's layout, detection curves and the "
        "noise figure, and run.json.",
    )
    option(b, OpenLoopConfig, "scenarios", type=names, shown="all")
    option(b, OpenLoopConfig, "jitter")
    add_detector_options(b)
    option(b, OpenLoopConfig, "seeds", type=positive_int)
    option(b, OpenLoopConfig, "dataset", metavar="DIR")
    add_config_file(b, "noise_levels, horizon, window", OpenLoopConfig)
    add_run_folder_options(b, "bench-open-loop")
    add_parallel_options(b, "clips")
    more = advanced(b, "the clips' first seed and frame size")
    option(more, OpenLoopConfig, "first_seed", type=non_negative_int)
    option(more, OpenLoopConfig, "resolution", type=resolution)


def closed_loop_config(args: argparse.Namespace) -> Any:
    """The configuration of ``bench closed-loop``'s arguments: a `ClosedLoopConfig`, or
    with --policies an `lgmd_sim.training.evaluate.EvalConfig`."""
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    hand_made = None if args.controllers is None else (
        () if args.controllers.strip() == "none" else names(args.controllers))
    detectors = (None if args.models is None and args.presets is None
                 else options.detectors(args.models or "all", args.presets))
    given = {"controllers": hand_made, "detectors": detectors, "jitter": _jitter(args),
             "seeds": args.seeds, "first_seed": args.first_seed}
    if args.policies is None:
        return configured(ClosedLoopConfig, args, {
            **given, "scenarios": args.scenarios, "resolution": args.resolution})
    from lgmd_sim.training.evaluate import EvalConfig

    for flag in ("scenarios", "resolution"):
        if getattr(args, flag) is not None:
            raise ValueError(f"--{flag} with --policies: the policies run in the scenario "
                             "and frame size they were trained in")
    return configured(EvalConfig, args, {**given, "policies": args.policies})


def _jitter(args: argparse.Namespace) -> tuple[float, ...] | None:
    # parsed here, not as the option's type: a bad level is one line, not the usage
    return None if args.jitter is None else options.jitter_levels(args.jitter)


def open_loop_config(args: argparse.Namespace) -> Any:
    """The `OpenLoopConfig` of ``bench open-loop``'s arguments."""
    from lgmd_sim.benchmark.open_loop import OpenLoopConfig

    detectors = (None if args.models == "all" and args.presets is None
                 else options.detectors(args.models, args.presets))
    return configured(OpenLoopConfig, args, {
        "scenarios": args.scenarios, "jitter": _jitter(args), "seeds": args.seeds,
        "first_seed": args.first_seed, "dataset": args.dataset, "detectors": detectors,
        "resolution": args.resolution})


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.benchmark import closed_loop, open_loop, summary
    from lgmd_sim.training import evaluate

    if args.what == "open-loop":
        job, config, markdown = open_loop.run, open_loop_config(args), open_loop.summary_markdown
    else:
        config = closed_loop_config(args)
        job = closed_loop.run if args.policies is None else evaluate.evaluate
        markdown = summary.summary_markdown
    result = job(config, args.out, run_options(args))
    return print_result(markdown(result.rows), result)
