"""The house's figures (issue 51's targets), measured from the checkout as it stands.

    python docs/experiments/tools/house.py [--json FILE]

Rooms are lgmd_sim's subpackages plus its loose modules; the CLI's leaf commands and
option entries are read from `lgmd-sim`'s own parser (-h not counted); the cruise
default is every literal 0.6 on a line of lgmd_sim that names the cruise; a signature
carries `ray_address` where a function takes it as a parameter; a test drives the CLI
where it calls `cli.main` or runs `lgmd-sim`/`lgmd_sim.cli` in a process.
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
PACKAGE = ROOT / "lgmd_sim"


def _leaves(parser: argparse.ArgumentParser, name: str) -> dict[str, int]:
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        return {name: sum(1 for a in parser._actions if a.option_strings
                          and not isinstance(a, argparse._HelpAction))}
    return {leaf: n for sub in subs for child, p in sub.choices.items()
            for leaf, n in _leaves(p, f"{name} {child}".strip()).items()}


def cli() -> dict[str, object]:
    from lgmd_sim.cli import build_parser
    parser = build_parser()
    leaves = {k: v for k, v in _leaves(parser, "").items()}
    listed = subprocess.run([sys.executable, "-m", "lgmd_sim.cli", "--help"],
                            capture_output=True, text=True).stdout
    return {"leaf commands": len(leaves), "option entries": sum(leaves.values()),
            "biggest command": max(leaves.items(), key=lambda kv: kv[1]),
            "speed or reference in --help": bool(re.search(r"\b(speed|reference)\b", listed))}


def code() -> dict[str, object]:
    modules = sorted(PACKAGE.rglob("*.py"))
    loose = [p.name for p in PACKAGE.glob("*.py") if p.name not in ("__init__.py", "__main__.py")]
    rooms = [p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()]
    lines = {str(p.relative_to(ROOT)): len(p.read_text().splitlines()) for p in modules}
    cruise = [f"{p.relative_to(ROOT)}:{i}" for p in modules
              for i, line in enumerate(p.read_text().splitlines(), 1)
              if "cruise" in line.lower() and re.search(r"(?<![\d.])0\.6(?!\d)", line)]
    ray = [f"{p.relative_to(ROOT)}:{node.name}" for p in modules
           for node in ast.walk(ast.parse(p.read_text()))
           if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
           and "ray_address" in {a.arg for a in [*node.args.args, *node.args.kwonlyargs]}]
    biggest = max(lines.items(), key=lambda kv: kv[1])
    return {"rooms": len(rooms) + len(loose), "loose top-level modules": loose,
            "biggest module": biggest,
            "modules over 500 lines": sum(n > 500 for n in lines.values()),
            "cruise default written": cruise, "signatures carrying ray_address": ray}


def tests() -> dict[str, object]:
    folders = [p.name for p in (ROOT / "tests").iterdir()
               if (p.is_dir() and (PACKAGE / p.name).is_dir()) or p.name == "cli"]
    drives = re.compile(r"cli\.main\(|\"lgmd-sim\"|lgmd_sim\.cli\"|LGMD_SIM\b")
    outside = [str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("test_*.py")
               if drives.search(p.read_text()) and "cli" not in p.relative_to(ROOT / "tests").parts]
    return {"test folders mirroring the package": sorted(folders),
            "CLI-driving test files outside tests/cli": len(outside)}


def repository() -> dict[str, object]:
    tracked = subprocess.run(["git", "ls-files", "docs"], cwd=ROOT, capture_output=True,
                             text=True, check=True).stdout.split()
    return {"tracked files under docs/": len(tracked)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args()
    figures = {**code(), **cli(), **tests(), **repository()}
    text = json.dumps(figures, indent=1)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
