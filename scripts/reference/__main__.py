"""`python -m scripts.reference`: the reference pages, generated from the code so that they cannot
drift: the scenarios (`scripts.reference.scenarios`) with a picture of each, and the command
line (`cli_page`: every command's --help, from the parser itself)."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path

from lgmd_sim.core.fileio import error_text

#: The width --help is wrapped to on the page, whatever the terminal's.
HELP_WIDTH = 100


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m scripts.reference",
        description="Write the reference pages into the folder --out: scenarios.md (each "
        "scenario's spaces, reward, episode end, info keys and arguments, from the "
        "environments themselves), cli.md (every command's --help) and "
        "scenes/<Scenario>.png (each scenario seen from outside). The tests compare the "
        "committed pages with what this writes: run it from the checkout's root after "
        "changing a scenario, the environment or an option.")
    p.add_argument("--out", default="docs/reference", metavar="DIR",
                   help="the folder to write into (default docs/reference)")
    p.add_argument("--no-pictures", action="store_true",
                   help="write the pages only, not the pictures (a few seconds each)")
    return p


def main(argv: list[str] | None = None) -> int:
    """`python -m scripts.reference`: the pages (and pictures) into --out, as one set; a bad
    --out or a failed write is one line on stderr and exit status 2."""
    args = build_parser().parse_args(argv)
    try:
        return _write(Path(args.out), pictures=not args.no_pictures)
    except (ValueError, OSError) as exc:
        print(f"python -m scripts.reference: error: {error_text(exc)}", file=sys.stderr)
        return 2


def _write(out: Path, *, pictures: bool) -> int:
    import cv2

    from lgmd_sim.core.fileio import write_files
    from scripts.reference import scenarios as reference

    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give the folder to write the pages into")
    pages = {out / "scenarios.md": reference.scenarios_page(), out / "cli.md": cli_page()}
    writers = {path: (lambda tmp, text=text: tmp.write_text(text, encoding="utf-8"))
               for path, text in pages.items()}
    if pictures:
        for name in reference.packaged():
            rgb = reference.scene_picture(name)
            png = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))[1].tobytes()
            writers[out / reference.SCENES / f"{name}.png"] = (
                lambda tmp, png=png: tmp.write_bytes(png))
    write_files(writers)
    for path in writers:  # one line a file, so that a long set of pictures stays readable
        print(f"wrote {path}")
    return 0


def _commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ("lgmd-sim",)
              ) -> Iterator[tuple[tuple[str, ...], str, argparse.ArgumentParser]]:
    """Every command's (path, one-line help, parser), the program's own first, then each
    subcommand's in the order --help lists them, depth first."""
    if len(path) == 1:
        yield path, parser.description or "", parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:  # one per command, aliases left out
                sub = action.choices[choice.dest]
                yield (*path, choice.dest), choice.help or "", sub
                yield from _commands(sub, (*path, choice.dest))


@contextlib.contextmanager
def _help_width(columns: int) -> Iterator[None]:
    """argparse wraps help to the terminal's width (COLUMNS): fix it while formatting."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(columns)
    try:
        yield
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous


def cli_page() -> str:
    """docs/reference/cli.md: a contents list, then every command's --help, and the keys of
    its --config file where it has one."""
    from lgmd_sim.cli import build_parser
    from scripts.reference.scenarios import REGENERATE

    commands = list(_commands(build_parser()))
    with _help_width(HELP_WIDTH):
        helps = [parser.format_help().rstrip() for _path, _summary, parser in commands]
    lines = ["# Command line", "",
             f"Generated from the code by `{REGENERATE}`; do not edit. Every command's "
             "`--help`, as `lgmd-sim COMMAND --help` prints it: first the program's own "
             "([lgmd-sim](#lgmd-sim)), then these.", ""]
    for path, summary, _parser in commands[1:]:  # the program's own help comes first
        title = " ".join(path)
        lines.append(f"{'  ' * (len(path) - 2)}- [{title}](#{title.replace(' ', '-')}): "
                     f"{summary}")
    for (path, _summary, parser), text in zip(commands, helps, strict=True):
        lines += ["", f"## {' '.join(path)}", "", "```text", text, "```"]
        lines += _config_keys(" ".join(path), parser)
    return "\n".join(lines) + "\n"


def _config_keys(command: str, parser: argparse.ArgumentParser) -> list[str]:
    """The keys of the command's --config file, each with its default and meaning, where
    its configuration declares them (`lgmd_sim.cli.args.add_config_file`)."""
    from lgmd_sim.core.configfile import keys_markdown

    classes = [c for a in parser._actions for c in getattr(a, "config_classes", ())]
    return [line for cls in classes for line in (
        "", f"The keys of `{command} --config FILE.toml` (`{cls.__name__}`):", "",
        keys_markdown(cls).rstrip())]


if __name__ == "__main__":
    sys.exit(main())
