"""The house's figures (issue 51's targets), measured from the checkout as it stands.

    python docs/experiments/tools/house.py [--json FILE] [--page]

--page writes the table of the figures before (docs/experiments/house/before.json) and now
into docs/experiments/house.md, between its markers.

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


#: What the page shows of each figure: (its key, label, target, how a value is shown).
ROWS = [
    ("rooms", "rooms (subpackages and loose modules)", "14 or fewer", None),
    ("loose top-level modules", "loose top-level modules", "0", len),
    ("leaf commands", "user CLI: leaf commands", "17 or fewer", None),
    ("option entries", "user CLI: option entries", "110 or fewer", None),
    ("speed or reference in --help", "`speed` or `reference` in `lgmd-sim --help`", "no",
     None),
    ("cruise default written", "the cruise default written", "once", len),
    ("signatures carrying ray_address", "signatures carrying `ray_address`", "0", len),
    ("test folders mirroring the package", "test folders mirroring the package",
     "5 or more", len),
    ("CLI-driving test files outside tests/cli", "CLI-driving test files outside tests/cli",
     "0", None),
    ("tracked files under docs/", "tracked files under docs/", "200 or fewer", None),
    ("biggest module", "biggest module (lines)", "500 or fewer", lambda v: f"{v[1]} ({v[0]})"),
    ("modules over 500 lines", "modules over 500 lines", "-", None),
]
BEFORE = ROOT / "docs/experiments/house/before.json"
PAGE = ROOT / "docs/experiments/house.md"
MARKS = ("<!-- house-figures -->", "<!-- /house-figures -->")


def table(before: dict, now: dict) -> str:
    def shown(value: object, how: object) -> str:
        value = how(value) if how else value
        return {True: "yes", False: "no"}.get(value, str(value)) if isinstance(value, bool) \
            else str(value)
    lines = ["| figure | before | now | target |", "|---|---:|---:|---|"]
    lines += [f"| {label} | {shown(before[key], how)} | {shown(now[key], how)} | {target} |"
              for key, label, target, how in ROWS]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    parser.add_argument("--page", action="store_true",
                        help="write the table of before and now into docs/experiments/house.md")
    args = parser.parse_args()
    figures = {**code(), **cli(), **tests(), **repository()}
    text = json.dumps(figures, indent=1)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    if args.page:
        page = PAGE.read_text()
        start, end = page.index(MARKS[0]) + len(MARKS[0]), page.index(MARKS[1])
        before = json.loads(BEFORE.read_text())
        PAGE.write_text(page[:start] + "\n" + table(before, figures) + "\n" + page[end:])


if __name__ == "__main__":
    main()
