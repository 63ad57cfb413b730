"""`lgmd-sim eval`: its command-line arguments (the implementation loads when it runs)."""

from __future__ import annotations

import argparse

from lgmd_sim.cli.args import (
    add_closed_loop_options,
    add_detector_options,
    add_parallel_options,
    add_run_folder_options,
)


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "eval", help="the closed-loop benchmark of trained policies beside the hand-made "
        "controllers (needs the rl extra)",
        description="Run `lgmd-sim bench closed-loop` with each POLICY as a controller of its "
        "own, beside Straight, Oracle and ReactiveAvoid with each detector, on the same "
        "held-out seeds, in the environment each policy was trained in. Writes the "
        "benchmark's tables and figures, and DIR/eval.md (collision and success rates and "
        "distance travelled per controller).",
    )
    p.add_argument("policies", nargs="*", metavar="POLICY",
                   help="policy folders (as lgmd-sim train writes them) or shipped policy "
                   "names (default: shipped, the shipped policy)")
    p.add_argument("--controllers", default="straight,oracle,reactive",
                   help="the hand-made controllers beside the policies, comma-separated, or "
                   "none (default straight,oracle,reactive)")
    add_detector_options(p)
    add_closed_loop_options(p, jitter="1,2")
    add_run_folder_options(p, "eval-out")
    add_parallel_options(p)
    p.set_defaults(run="lgmd_sim.training.evaluate:evaluate")
