"""`lgmd-sim models`: the models (the built-ins, the registered and those of installed
distributions), their presets (a calibrated one with the file it comes from) and every
parameter with its source."""

from __future__ import annotations

import argparse


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "models", help="list the LGMD models and their parameters with sources",
        description="List the LGMD models (the built-ins, then those of installed "
        "distributions, their entry points in the group lgmd_sim.models), their presets "
        "(each calibrated one with the file it comes from: shipped with the package, or "
        "your presets file, $LGMD_SIM_DATA_DIR/calibrated.json) and every parameter with "
        "its default and where that default comes from.",
    )
    which = p.add_mutually_exclusive_group()
    which.add_argument("name", nargs="?",
                       help="show one model only (a name, or a package.module:Class spec)")
    which.add_argument("--check", metavar="SPEC",
                       help="check that model SPEC (a name or package.module:Class spec, "
                       "optionally /preset and front ends) keeps the model contract: "
                       "streaming equals batched, reset, determinism, potentials in range, "
                       "parameters with sources and checks, the front ends, the search space; "
                       "prints each check passed or skipped (and why), or exits with status "
                       "2 and what is wrong")


def run(args: argparse.Namespace) -> int:
    """`lgmd-sim models`: every model, its presets and parameters with their sources."""
    from lgmd_sim import models
    from lgmd_sim.models.presets import CALIBRATED, preset_files

    if args.check:
        return _check(args.check)
    names = [args.name] if args.name else models.available()
    for name in names:
        cls = models.model_class(name)
        origin = models.origin(name)
        summary = (cls.__doc__ or "").strip().partition("\n")[0]
        print(f"{name}: {summary}" + ("" if origin == "built-in" else f" ({origin})"))
        presets = models.presets_of(name)
        files = preset_files(name)
        listed = [p if p not in files else
                  f"{p} ({'shipped' if files[p] == CALIBRATED else files[p]})" for p in presets]
        print(f"  presets: {', '.join(listed)} (default {next(iter(presets))})")
        for pname, default, source, _doc in cls.Params.describe():
            print(f"  {pname} = {default!r}  [{source}]")
        print()
    return 0


def _check(spec: str) -> int:
    """`lgmd-sim models --check SPEC`: what it checked and skipped; a failure is a
    ValueError."""
    from lgmd_sim.models.check import CHECKS, check_model

    done = check_model(spec)
    skipped = sum(result != "passed" for _, result in done)
    print(f"{spec}: passes {len(done) - skipped} checks, skips {skipped}")
    for title, result in done:
        what = " ".join((CHECKS[title].__doc__ or "").split()) if result == "passed" else (
            f"skipped ({result.removeprefix('skipped: ')})")
        print(f"  {title}: {what}")
    return 0
