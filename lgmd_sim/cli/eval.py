"""`lgmd-sim eval`: its command-line arguments (the implementation loads when it runs)."""

from __future__ import annotations

import argparse

from lgmd_sim.cli.args import non_negative_int, positive_int


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
    p.add_argument("--models", default="all",
                   help="detectors of the reactive controller: 'all' or MODEL[/PRESET],... "
                   "(default all)")
    p.add_argument("--presets", default=None,
                   help="comma-separated presets for the models listed without one")
    p.add_argument("--jitter", default="1,2", help="comma-separated jitter levels "
                   "(default 1,2)")
    p.add_argument("--seeds", type=positive_int, default=50, help="episodes per cell "
                   "(default 50)")
    p.add_argument("--first-seed", type=non_negative_int, default=1000,
                   help="the first episode seed (default 1000: never a training or "
                   "validation seed)")
    p.add_argument("--cruise", type=float, default=0.6,
                   help="forward action of the cruising controllers (default 0.6)")
    p.add_argument("--horizon", type=float, default=2.0,
                   help="an alarm is false when no obstacle is within this time to "
                   "collision (s, default 2)")
    p.add_argument("--out", default="eval-out", metavar="DIR",
                   help="output folder (default ./eval-out)")
    p.add_argument("--resume", action="store_true",
                   help="complete the run in DIR (same configuration)")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes (default: every core)")
    p.add_argument("--ray", metavar="ADDRESS", default=None,
                   help="run the episodes as Ray tasks: 'local', 'auto' or HOST:PORT")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(run="lgmd_sim.training.evaluate:evaluate")
