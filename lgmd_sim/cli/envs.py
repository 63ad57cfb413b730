"""`lgmd-sim envs`: its command-line arguments (the implementation loads when it runs)."""

from __future__ import annotations

import argparse


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "envs", help="list the registered scenarios and their parameters",
        description="List the Gymnasium scenarios (lgmd_sim/<Name>-v0) of the catalogue in "
        "envs/, with their parameters and defaults.",
    )
    p.add_argument("name", nargs="?", help="show one scenario only")
    p.set_defaults(run="lgmd_sim.envs.catalogue:run_list")
