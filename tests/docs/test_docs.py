"""The documents hold together: every relative link leads to a file, and the leaderboard's
numbers on the pages come from the run folders they name."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from lgmd_sim.core.parallel import RunOptions

ROOT = Path(__file__).resolve().parents[2]
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


# --- the API reference's closed-loop example (issue 49, item 17) ----------------------------

API = ROOT / "docs" / "reference" / "api.md"


def _closed_loop_example_config():
    """The ClosedLoopConfig the API reference's closed-loop example makes, as it stands."""
    import ast

    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    section = API.read_text().split("## Closed-loop benchmark", 1)[1]
    code = re.search(r"^```python\n(.*?)^```", section, re.S | re.M).group(1)
    calls = [node for node in ast.walk(ast.parse(code)) if isinstance(node, ast.Call)
             and getattr(node.func, "id", None) == "ClosedLoopConfig"]
    assert len(calls) == 1, "the closed-loop example makes no (or several) ClosedLoopConfig"
    return eval(compile(ast.Expression(calls[0]), str(API), "eval"),
                {"ClosedLoopConfig": ClosedLoopConfig})


def test_the_api_closed_loop_example_drives_a_robot_among_obstacles():
    """On a tripod (StationaryApproach) no controller moves the camera: every one, the
    Oracle too, collides in every episode, and the example would show no difference."""
    from lgmd_sim.envs.catalogue import params_for

    config = _closed_loop_example_config()
    for name in config.scenarios:
        params = params_for(name, {})
        assert params.carrier == "robot", f"{name}: carrier {params.carrier}, not driven"
        assert params.n_obstacles > 0, f"{name}: nothing to avoid"


@pytest.mark.slow
def test_the_api_closed_loop_example_s_controllers_differ(tmp_path):
    """The example as configured: the floor (straight) collides more often than the ceiling
    (the Oracle), as the text below it says."""
    from lgmd_sim.benchmark.closed_loop import run

    rows = run(_closed_loop_example_config(), tmp_path / "run",
               RunOptions(workers=1, progress=False)).rows
    rate = {(r["controller"], r["model"]): r["collision_rate"] for r in rows}
    assert rate["straight", None] == 1.0 and rate["oracle", None] == 0.0, rate
    assert "`straight` collides in both, the Oracle in neither" in " ".join(
        API.read_text().split())


# --- the LGMD2 paper's citation (issue 49, item 18) ------------------------------------------

REFERENCES = ROOT / "docs" / "references.md"
#: The pages for users: README and docs/ but the research log and references.md itself.
USER_PAGES = [ROOT / "README.md", *(p for p in sorted((ROOT / "docs").rglob("*.md"))
                                    if "experiments" not in p.relative_to(ROOT).parts
                                    and p != REFERENCES)]
#: "Fu et al. 2020", "Fu, Hu, Peng, Rind, Yue: IEEE TCYB 2019", "Fu et al. 2018, 2019"; not
#: a later author's ("Chang, Fu et al."). Group 1: the years.
FU = r"(?<!, )\bFu(?: et al\.|, Hu, Peng\b)[^;()\d]{0,40}?(\d{4}(?:,\s*\d{4})*)"


def _years(text: str) -> list[int]:
    return [int(y) for y in re.findall(r"\d{4}", text)]


def _reference_years() -> tuple[int, set[int]]:
    """references.md's year of the LGMD2 paper, and of every entry Q. Fu is first author of
    (its list of entries, "**[N]** Q. Fu, ...": the title in quotes, the venue, ", YEAR")."""
    text = REFERENCES.read_text()
    bib = re.search(r"^@\w+\{\w*lgmd2\w*,(.*?)^\}", text, re.S | re.M)
    assert bib, "docs/references.md has no BibTeX entry for LGMD2"
    bib_year = int(re.search(r"\byear\s*=\s*\{(\d{4})\}", bib.group(1)).group(1))
    entries = re.findall(r"^\*\*\[\d+\]\*\* (.*?)(?=^\*\*\[|^#|\Z)", text, re.S | re.M)
    first_year = {entry: int(re.search(r',"[^"]*?, (\d{4})\b', entry).group(1))
                  for entry in entries if entry.startswith("Q. Fu,")}
    lgmd2 = [year for entry, year in first_year.items() if "LGMD2 (`lgmd2`)" in entry]
    assert lgmd2 == [bib_year], f"references.md: LGMD2's entry {lgmd2}, its BibTeX {bib_year}"
    return bib_year, set(first_year.values())


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_fu_et_al_citation_gives_the_year_references_md_does(page):
    lgmd2_year, fu_years = _reference_years()
    text = " ".join(page.read_text().split())  # a citation may break across lines
    wrong = [f"'{m.group(0)}': no entry of Q. Fu's in docs/references.md has that year "
             f"({sorted(fu_years)})" for m in re.finditer(FU, text)
             if not set(_years(m.group(1))) <= fu_years]
    # the paper of the model: "LGMD2: Fu et al. 2020", "`lgmd2` (Fu et al. 2020)", ...
    wrong += [f"'{m.group(0)}': the LGMD2 paper is {lgmd2_year} (docs/references.md [5])"
              for m in re.finditer(r"\bLGMD2`?\W{1,4}" + FU, text, re.I)
              if set(_years(m.group(1))) != {lgmd2_year}]
    assert not wrong, f"{page.relative_to(ROOT)}: " + "; ".join(wrong)


def test_the_citation_check_sees_the_wrong_years():
    """The pattern reads the forms the pages used: a wrong year is caught in each."""
    for text in ("`lgmd2` (Fu et al. 2018, 2019)", "LGMD2 (Fu, Hu, Peng, Rind, Yue: IEEE "
                 "TCYB 2019; Neural Networks 2018)", "LGMD2: Fu et al. 2019; F(ONn)"):
        match = re.search(r"\bLGMD2`?\W{1,4}" + FU, text, re.I)
        assert match and 2019 in _years(match.group(1)), text
    assert not re.search(FU, "the oLGMD of Chang, Fu et al. (Biomimetics 2024")
