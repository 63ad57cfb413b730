"""The documents hold together: every relative link leads to a file, and the leaderboard's
numbers on the pages come from the run folders they name."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "CONTRIBUTING.md", ROOT / "CHANGELOG.md",
         *sorted((ROOT / "docs").rglob("*.md"))]
# [text](target) and ![alt](target), not inside code spans; a target without a scheme.
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
LEADERBOARD = ROOT / "docs" / "leaderboard.md"


def _links(page: Path) -> list[str]:
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.S | re.M)
    text = re.sub(r"`[^`\n]*`", "", text)
    return [t for t in LINK.findall(text) if not re.match(r"[a-z]+:", t)]


@pytest.mark.parametrize("page", [p for p in PAGES if p.exists()],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_of_a_page_leads_to_a_file(page):
    broken = [t for t in _links(page)
              if t.split("#")[0] and not (page.parent / t.split("#")[0]).exists()]
    assert not broken, f"{page.relative_to(ROOT)}: broken links {broken}"


def _rows(text: str) -> list[str]:
    return [line for line in text.splitlines() if re.match(r"\| (=?\d+|-) \| `", line)]


def test_the_readme_s_leaderboard_rows_are_the_leaderboard_s():
    shown = _rows((ROOT / "README.md").read_text())
    assert shown, "the README shows no leaderboard row"
    board = _rows(LEADERBOARD.read_text())
    assert not [row for row in shown if row not in board], \
        "README rows differ from docs/leaderboard.md: copy them again from it"


def test_the_leaderboard_page_is_what_its_results_make_now(tmp_path):
    """docs/leaderboard.md is `lgmd-sim leaderboard` over the result files it names, as the
    code ranks them today."""
    from lgmd_sim.benchmark import protocol
    from lgmd_sim.benchmark.leaderboard import leaderboard

    text = LEADERBOARD.read_text()
    names = re.findall(r"^- `[^`]+` \(([^)]+/result\.json)\)", text, re.M)
    assert names and all((ROOT / n).is_file() for n in names), names
    out = tmp_path / "leaderboard.md"
    leaderboard([ROOT / n for n in names], out, protocol.load())
    made = out.read_text().replace(str(ROOT) + "/", "")
    assert made == text, ("docs/leaderboard.md is stale: " + shlex.join(
        ["lgmd-sim", "leaderboard", *names, "--out", "docs/leaderboard.md"]))


def _commands(page: Path) -> list[str]:
    """The `lgmd-sim ...` lines of a page's shell blocks, continuations joined, comments and
    an environment assignment in front dropped."""
    found = []
    for kind, block in re.findall(r"^```(bash|sh|console)\n(.*?)^```", page.read_text(),
                                  re.S | re.M):
        for line in block.replace("\\\n", " ").splitlines():
            if kind == "console" and not line.startswith("$ "):
                continue  # the command's output
            line = re.sub(r"^(\w+=\S+ )+", "", line.removeprefix("$ ").strip())
            if line.startswith("lgmd-sim "):
                found.append(re.split(r"\s+#|\s*[|>]\s*", line)[0])
    return found


COMMANDS = [(p, c) for p in PAGES if p.exists() for c in _commands(p)]


@pytest.mark.parametrize(("page", "command"), COMMANDS,
                         ids=[f"{p.relative_to(ROOT)}:{c[:40]}" for p, c in COMMANDS])
def test_every_command_of_a_page_is_one_the_command_line_takes(page, command):
    """Every `lgmd-sim` line of the documents parses as it stands: a renamed or removed
    option fails here (the walkthroughs and examples run whole elsewhere)."""
    from lgmd_sim.cli import build_parser

    try:
        build_parser().parse_args(shlex.split(command)[1:])
    except SystemExit as exit:
        if exit.code == 0:  # --help
            return
        pytest.fail(f"{page.relative_to(ROOT)}: `{command}` is refused (exit {exit.code})")
