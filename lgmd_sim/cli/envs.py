"""`lgmd-sim envs`: the scenarios of the catalogue (`lgmd_sim.envs.catalogue`) with their
parameters; broken scenario files one line each."""

from __future__ import annotations

import argparse
import sys


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "envs", help="list the registered scenarios and their parameters",
        description="List the Gymnasium scenarios (lgmd_sim/<Name>-v0) of the catalogue in "
        "envs/, with their parameters and defaults.",
    )
    p.add_argument("name", nargs="?", help="show one scenario only")


def run(args: argparse.Namespace) -> int:
    """`lgmd-sim envs [name]`: the scenarios with their parameters; broken files, one line
    each on stderr (exit status 2)."""
    from lgmd_sim.envs.catalogue import catalogue_errors, params_for, scenario, scenarios
    from lgmd_sim.envs.params import EnvParams

    if args.name:
        sc = scenario(args.name)
        params = params_for(sc.name, {})
        print(f"{sc.env_id}: {sc.description}  ({sc.path})")
        for pname, _default, source, doc in EnvParams.describe():
            mark = "*" if pname in sc.overrides else " "
            print(f" {mark}{pname} = {getattr(params, pname)!r}  # {doc} [{source}]")
        print("  (* set by the scenario; override any with gym.make(id, name=value))")
        return 0
    defaults = {n: d for n, d, _s, _doc in EnvParams.describe()}
    problems = catalogue_errors()
    for name, sc in scenarios().items():
        try:
            params = params_for(name, {})
        except ValueError as exc:
            problems.append(str(exc))
            continue
        print(f"{sc.env_id}: {sc.description}")
        for pname in sc.overrides:
            print(f"    {pname} = {getattr(params, pname)!r}  (default {defaults[pname]!r})")
        print()
    for problem in problems:
        print(f"lgmd-sim envs: error: {problem}", file=sys.stderr)
    return 2 if problems else 0
