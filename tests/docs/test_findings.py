"""docs/findings.md: each finding is a short paragraph, one figure and the command that
made it, and every number its paragraph quotes is in a file of the repository the finding
links (a run folder's summary or tables, a result file, the shipped presets file, the
leaderboard, the models reference)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "findings.md"
EXPERIMENTS = ROOT / "docs" / "experiments"
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
# The numbers a paragraph quotes: 0.625, 97%, 4/12. Plain integers (jitter levels, counts,
# equation numbers) are left out: too many of them match anything.
NUMBER = re.compile(r"(?<![\w./])(\d+/\d+|\d*\.\d+%?|\d+%)(?![\w/])")
# A number quoted from outside the repository's runs, to the end of its clause: an issue's
# target or the paper's own value, typed by hand with its source named.
QUOTED = re.compile(r"\b(?:[Ii]ssue\s+\d+|[Tt]he paper\b).*?[.;)](?=\s|$)", re.S)
# A number a source writes: a fraction, or a value with the character after it (a percent
# sign, or a table's " [" or " |" that marks a percentage written as a whole number).
SOURCE_NUMBER = re.compile(r"(?<![\w./])(\d+/\d+|\d+(?:\.(\d+))?)(%| \[| \|)?")
# The parts of a JSON source that hold measurements (a preset's search and held-out
# objective, a result's metrics and intervals); a detector's parameters are not quoted.
MEASURED = {"search", "heldout", "metrics", "intervals"}


def _slug(heading: str) -> str:
    """A heading's anchor as GitHub makes it."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _section(text: str, anchor: str) -> str:
    """The part of a page under the heading with this anchor, down to the next heading of
    its level or above."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        level = len(line) - len(line.lstrip("#"))
        if level and _slug(line[level:]) == anchor:
            end = next((j for j in range(i + 1, len(lines))
                        if 0 < len(lines[j]) - len(lines[j].lstrip("#")) <= level), len(lines))
            return "\n".join(lines[i:end])
    raise AssertionError(f"no heading with the anchor #{anchor}")


def _findings(text: str) -> list[tuple[str, str]]:
    parts = re.split(r"^## (.+)$", text, flags=re.M)
    return list(zip(parts[1::2], parts[2::2], strict=True))


def _json_text(data: Any, measured: bool = False) -> str:
    """A JSON file's prose (its strings) and its measured numbers, as text."""
    if isinstance(data, dict):
        return "\n".join(_json_text(v, measured or k in MEASURED) for k, v in data.items())
    if isinstance(data, list):
        return "\n".join(_json_text(v, measured) for v in data)
    if isinstance(data, str):
        return data
    if isinstance(data, bool) or data is None or not measured:
        return ""
    # a float to six decimals, so that 1.0 reads as a share (100%) as 0.96875 does (97%)
    return f"{data:.6f}" if isinstance(data, float) else str(data)


def _files(body: str) -> list[tuple[Path, str]]:
    """The files of the repository a finding links (its figure too), each with the anchor
    of its link."""
    out = []
    for target in LINK.findall(body):
        path, _, anchor = target.partition("#")
        out.append(((PAGE.parent / path).resolve(), anchor))
    return out


def _sources(body: str) -> str:
    """The text of the sources a finding links: a Markdown page (an anchored link: its
    section), a JSON file's strings and measurements (a link with a JSON Pointer: the part
    it points at). The research log is no source: its tables keep runs that are gone, as
    history."""
    out = []
    for path, anchor in _files(body):
        if EXPERIMENTS in path.parents:
            continue
        if path.suffix == ".md":
            text = path.read_text()
            out.append(_section(text, anchor) if anchor else text)
        elif path.suffix == ".json":
            # a fragment is a JSON Pointer (#/presets/lgmd1/robot-imu): that part only
            keys = [k.replace("~1", "/").replace("~0", "~") for k in anchor.split("/")[1:]]
            data = json.loads(path.read_text())
            for key in keys:
                assert isinstance(data, dict) and key in data, f"{path.name}#{anchor}: no {key}"
                data = data[key]
            out.append(_json_text(data, measured=bool(MEASURED & set(keys))))
    return "\n".join(out)


def quotable(sources: str) -> set[str]:
    """Every way a paragraph may quote a number of `sources`: as written, rounded to fewer
    decimals (0.96875: 0.97, 0.969), and a share of two decimals or more as a whole
    percentage (0.96875: 97%); a whole percentage as written (97%, a table's 97 [95% CI] or
    | 97 |)."""
    out = set()
    for number, decimals, after in SOURCE_NUMBER.findall(sources):
        if "/" in number:
            out.add(number)
        elif after == "%":
            out.update({f"{number}%", f"{float(number):.0f}%"})
        elif decimals:
            value = float(number)
            out.update(f"{value:.{k}f}" for k in range(1, len(decimals) + 1))
            if len(decimals) >= 2 and value <= 1:
                out.add(f"{100 * value:.0f}%")
        elif after:
            out.add(f"{number}%")
    return out


def unsourced(paragraph: str, sources: str) -> list[str]:
    """The numbers of `paragraph` that `sources` does not hold, the quoted ones (an issue's
    target, the paper's value) left out."""
    held = quotable(sources)
    return [number for number in NUMBER.findall(QUOTED.sub("", paragraph))
            if number not in held]


FINDINGS = _findings(PAGE.read_text())


def test_the_page_opens_with_the_leaderboard_and_holds_findings():
    head = PAGE.read_text().split("\n## ")[0]
    assert "](leaderboard.md)" in head
    assert len(FINDINGS) >= 5


@pytest.mark.parametrize(("title", "body"), FINDINGS, ids=[t[:40] for t, _ in FINDINGS])
def test_a_finding_is_a_short_paragraph_a_figure_and_its_command(title, body):
    paragraph, figure, _ = re.split(r"^(!\[.*)$", body, maxsplit=1, flags=re.M)
    lines = [line for line in paragraph.splitlines() if line.strip()]
    assert 3 <= len(lines) <= 6, f"{title}: {len(lines)} lines"
    (image,) = LINK.findall(figure)
    assert (PAGE.parent / image).is_file(), image
    assert re.search(r"^```bash\n(lgmd-sim|\.venv/bin/python|python) ", body, re.M), title


@pytest.mark.parametrize(("title", "body"), FINDINGS, ids=[t[:40] for t, _ in FINDINGS])
def test_every_number_of_a_finding_is_in_a_source_it_links(title, body):
    paragraph = body.split("\n![")[0]
    assert NUMBER.search(paragraph), f"{title}: quotes no number"
    missing = unsourced(paragraph, _sources(body))
    assert not missing, f"{title}: numbers in none of the files it links: {missing}"


@pytest.mark.parametrize(("title", "body"), FINDINGS, ids=[t[:40] for t, _ in FINDINGS])
def test_the_files_a_finding_links_are_kept_in_the_repository(title, body):
    """A finding's sources and figure are files of the repository, none of them a path
    .gitignore leaves on the machine that ran it (a run folder under runs/, records), and
    a page's anchor is one of its headings."""
    files = [path for path, _ in _files(body)]
    assert all(path.is_file() for path in files), title
    for path, anchor in _files(body):
        if path.suffix == ".md" and anchor:
            _section(path.read_text(), anchor)
    git = shutil.which("git")
    if git is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    ignored = subprocess.run([git, "check-ignore", *map(str, files)], cwd=ROOT,
                             capture_output=True, text=True).stdout.split()
    assert not ignored, f"{title}: links files git ignores: {ignored}"


def test_a_number_typed_by_hand_is_caught():
    sources = "| lgmd1 | 0.92 | 40 [26, 55] | 4/12 | 0.97 | 6% of 12 clips"
    assert unsourced("SI 0.92, 40% of them, 4/12 fired, 97% late, 12%, 6%", sources) == [
        "12%"]
    assert unsourced("SI 0.93, 41% of them, 5/12 fired, 0.8 late, 26%", sources) == [
        "0.93", "41%", "5/12", "0.8", "26%"]
    # a rounding of a source's value is that value: 0.92 is 0.9 to one decimal
    assert unsourced("SI 0.9", sources) == []
    # an issue's target is the issue's, the paper's value the paper's, not a run's
    assert unsourced("Issue 9's target was 85% or more. Here 0.92.", sources) == []
    assert unsourced("SI 0.97 (the paper: 0.88); 0.93 here", sources) == ["0.93"]


def test_a_json_source_gives_its_measurements_not_its_parameters():
    preset = {"params": {"threshold": 0.765},
              "calibration": {"objective": "a window of [0.6, 1.15] s"},
              "heldout": {"objective": 0.96875, "near_miss": 0.9375, "stationary": 1.0}}
    text = _json_text(preset)
    assert unsourced("held out 0.969, 97% late, 94% rejected, 100% before, in [0.6, 1.15] s",
                     text) == []
    assert unsourced("threshold 0.765; 96% late", text) == ["0.765", "96%"]


def test_a_json_pointer_narrows_a_source_and_the_research_log_is_none():
    presets = "../lgmd_sim/models/calibrated.json#/presets/lgmd1/robot-imu"
    held_out = _sources(f"[lgmd1/robot-imu]({presets}/heldout)")
    assert unsourced("0.625", held_out) == []
    # its search value and its threshold (a parameter) are not its held-out values
    assert unsourced("0.573; 0.965", held_out) == ["0.573", "0.965"]
    assert unsourced("0.573", _sources(f"[lgmd1/robot-imu]({presets})")) == []
    with pytest.raises(AssertionError, match="no heldout"):
        _sources("[x](../lgmd_sim/models/calibrated.json#/presets/heldout)")
    assert _sources("[log](experiments/results-log.md#calibration)") == ""
