"""`lgmd-sim verify`: replay a benchmark row's episodes here and say whether they give the
same bits as recorded, and where they part if not."""

from __future__ import annotations

import argparse
import sys

from lgmd_sim.cli.args import advanced, non_negative_int, positive_int


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "verify", help="replay a benchmark result's episodes and compare them with its records",
        description="Replay a sample of the closed-loop episodes of a benchmark result "
        "(OUT/ENTRY/result.json, beside its goal/ and arena/ run folders) on this machine and "
        "compare each with its record: identical (the same bits: every frame, position, "
        "action and potential, by its fingerprint, and the same measures), or where it "
        "parted. Also refuses a result whose scores are not what its parts give, or whose "
        "parts are not what its records give. Exit 0 when every replayed episode is "
        "identical, 1 when one is not. A plug-in's module must be on PYTHONPATH as it was "
        "for the benchmark (the result's command says how).")
    p.add_argument("result", metavar="RESULT", help="a result.json, or its entry's folder")
    p.add_argument("--episodes", type=positive_int, default=8, metavar="N",
                   help="episodes replayed per track, drawn by --seed (default 8; a goal "
                   "track of the shipped protocol holds 120)")
    p.add_argument("--all", action="store_true", help="replay every episode")
    p.add_argument("--workers", type=positive_int, default=None,
                   help="local worker processes (default: every core)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    more = advanced(p, "another protocol than the shipped one, another sample")
    more.add_argument("--protocol", default="v2", metavar="NAME|FILE",
                      help="the protocol the result ran (default v2)")
    more.add_argument("--seed", type=non_negative_int, default=0,
                      help="the sample's seed (default 0)")


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.benchmark import protocol
    from lgmd_sim.benchmark.verify import Replayed, verify
    from lgmd_sim.core.numerics import mode
    from lgmd_sim.core.parallel import RunOptions

    def say(checked: Replayed) -> None:
        print(f"{checked.track} {checked.key}: {checked.difference or 'identical'}",
              flush=True)

    checked = verify(args.result, protocol.load(args.protocol),
                     None if args.all else args.episodes, seed=args.seed,
                     options=RunOptions(workers=args.workers,
                                        progress=False if args.no_progress else None),
                     on_episode=say)
    same = sum(c.difference is None for c in checked)
    print(f"{same} of {len(checked)} episodes identical, numerics {mode()} "
          "(lgmd_sim.core.numerics)")
    if same < len(checked):
        print("lgmd-sim verify: the row does not replay here: see the episodes above",
              file=sys.stderr)
        return 1
    return 0
