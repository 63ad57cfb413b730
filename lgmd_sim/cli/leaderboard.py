"""`lgmd-sim leaderboard`: benchmark results merged into one ranked table and a figure."""

from __future__ import annotations

import argparse


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "leaderboard", help="merge benchmark results into a ranked Markdown table and a figure",
        description="Merge the results of `lgmd-sim benchmark` (each entry's result.json, or "
        "its folder) into FILE.md, ranked by the overall score, each entry compared with the "
        "one above it on the same seeds ('=': not separable, the interval of the paired "
        "difference holds 0), and FILE.png (score by entry, track and jitter level). Every "
        "result must be of the protocol given (refused in one line otherwise).")
    p.add_argument("results", nargs="+", metavar="RESULT",
                   help="result.json files or the entries' folders")
    p.add_argument("--out", required=True, metavar="FILE.md", help="the table to write")
    p.add_argument("--protocol", default="v2", metavar="NAME|FILE",
                   help="the protocol the results ran (default v2)")


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.benchmark import protocol
    from lgmd_sim.benchmark.leaderboard import leaderboard

    files = leaderboard(args.results, args.out, protocol.load(args.protocol))
    print(f"wrote {', '.join(map(str, files))}")
    return 0
