"""`lgmd-sim eval`: its arguments, and the `EvalConfig` made from them."""

from __future__ import annotations

import argparse
from typing import Any

from lgmd_sim.cli.args import (
    add_closed_loop_options,
    add_detector_options,
    add_parallel_options,
    add_run_folder_options,
    advanced,
    print_result,
    run_options,
)
from lgmd_sim.controllers import options
from lgmd_sim.core.extras import install_command
from lgmd_sim.policies import EVAL_SEEDS, EVAL_TOP_VIEWS


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "eval", help="the closed-loop benchmark of trained policies beside the hand-made "
        "controllers (needs the rl extra)",
        description="Run `lgmd-sim bench closed-loop` with each POLICY as a controller of its "
        "own, beside Straight, Oracle and ReactiveAvoid with each detector, on the same "
        "held-out seeds, in the environment each policy was trained in. Writes the "
        "benchmark's tables and figures, and DIR/eval.md (collision and success rates and "
        "distance travelled per controller). Needs the rl extra, stable-baselines3 and "
        f"PyTorch (install it {install_command('rl')}). Trust: a policy folder is "
        "policy.json and policy.npz, the network's weights as plain arrays, loaded without "
        "unpickling, so evaluating a policy from anyone runs none of its author's code: "
        "its policy.json may name a built-in, registered or installed model, and a "
        "plug-in's spec (code) only where --models names it too. "
        "stable-baselines3's own files are pickles, which run whatever their author put in "
        "them when loaded: eval never reads them, but "
        "`lgmd-sim train --resume DIR` loads DIR/checkpoints/ (model.zip, vecnormalize.pkl, "
        "replay_buffer.pkl) and `python -m lgmd_sim.policies.convert DIR` an older "
        "folder's policy.zip: use those only on files you made or from someone you trust.",
    )
    p.add_argument("policies", nargs="*", metavar="POLICY",
                   help="policy folders (policy.json and policy.npz, as lgmd-sim train writes "
                   "them) or shipped policy names (default: shipped, the shipped policy)")
    p.add_argument("--controllers", default="straight,oracle,reactive",
                   help="the hand-made controllers beside the policies, comma-separated, or "
                   "none (default straight,oracle,reactive)")
    add_detector_options(p, default=None, means="the LGMD models the policies observe, "
                         "at their presets (all, each at its default preset, when none "
                         "observes one)")
    more = advanced(p, "the episodes' first seed, cruise speed and false-alarm horizon, the "
                    "figures, and Ray")
    add_closed_loop_options(p, more, jitter="1,2", seeds=EVAL_SEEDS, top_views=EVAL_TOP_VIEWS)
    add_run_folder_options(p, "eval-out")
    add_parallel_options(p, more)


def config_from_args(args: argparse.Namespace) -> Any:
    """The `EvalConfig` of ``eval``'s arguments."""
    from lgmd_sim.training.evaluate import EvalConfig

    hand_made = () if args.controllers.strip() == "none" else tuple(
        options.comma_list(args.controllers))
    return EvalConfig(
        policies=tuple(args.policies), controllers=hand_made,
        detectors=None if args.models is None and args.presets is None
        else options.detectors(args.models or "all", args.presets),
        jitter=options.jitter_levels(args.jitter), seeds=args.seeds,
        first_seed=args.first_seed, cruise=args.cruise, horizon=args.horizon,
        top_views=args.top_views)


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.benchmark.summary import summary_markdown
    from lgmd_sim.training.evaluate import evaluate

    result = evaluate(config_from_args(args), args.out, run_options(args))
    return print_result(summary_markdown(result.rows), result)
