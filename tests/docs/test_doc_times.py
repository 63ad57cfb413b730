"""Every duration a user page states (README, CONTRIBUTING, docs/ but the research log)
comes from a record, with its machine: a block of text (a paragraph, a list item, a table
row, a line of code) that says "N min" or "N hours" names a run's `result.json` or
`run.json`, each such number is that record's wall time, and the block names the
record's processor. A time nothing records is no time to state (issue 49, item 15).

The one exception is CONTRIBUTING.md's test-tier times, measured by hand at a release and
kept between `<!-- test-times ... -->` and `<!-- /test-times -->` so that they are changed
together. Times printed by a command (```text blocks, the command above them) are its
output, not a claim of the page's."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", ROOT / "CONTRIBUTING.md",
         *sorted(p for p in (ROOT / "docs").rglob("*.md")
                 if "experiments" not in p.relative_to(ROOT / "docs").parts)]

_NUMBER = r"(\d+(?:\.\d+)?|one|two|three|four|five|six|seven|eight|nine|ten|fifteen|twenty)"
#: A duration in minutes or hours ("17 min", "about 10 minutes", "five minutes", "2 h");
#: not a rate ("false alarms / min", "6 a minute").
LONG = re.compile(_NUMBER + r"\s*(min|minutes?|h|hours?)\b(?!\s*/)", re.I)
#: In a block that names a record, its seconds too ("1006.9 s").
SECONDS = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?)\s*(s|seconds?)\b(?!\s*/)")
WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7,
         "eight": 8, "nine": 9, "ten": 10, "fifteen": 15, "twenty": 20}
RECORD = re.compile(r"[\w./-]*\b(?:result|run)\.json")
EXEMPT = re.compile(r"<!-- test-times\b.*?-->(.*?)<!-- /test-times -->", re.S)


def blocks(text: str) -> list[tuple[int, str]]:
    """(first line number, text) of each block: a paragraph, a list item or a table row
    outside code, a line inside it; none of a command's printout (```text)."""
    found: list[tuple[int, list[str]]] = []
    fence, current = None, None
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fence = None if fence is not None else line.strip()[3:]
            current = None
            continue
        if fence is not None:
            if fence != "text":
                found.append((number, [line]))
            continue
        if not line.strip():
            current = None
            continue
        if current is None or re.match(r"\s*([-*|]|\d+\.)\s", line):
            current = [line]
            found.append((number, current))
        else:
            current.append(line)
    return [(number, " ".join(lines)) for number, lines in found]


def _value(word: str) -> float:
    return float(WORDS.get(word.lower(), word))


def _close(stated: str, value: float) -> bool:
    """`stated` is `value` rounded to its own digits (an integer: to the unit)."""
    places = len(stated.split(".")[1]) if "." in stated else 0
    return abs(_value(stated) - value) <= 0.5 * 10 ** -places + 1e-9


def _records(page: Path, block: str) -> list[dict]:
    """The records a block names: links relative to the page, or paths from the root."""
    records = []
    for name in RECORD.findall(block):
        for path in (page.parent / name, ROOT / name):
            if path.is_file():
                data = json.loads(path.read_text())
                wall = data.get("timing", data).get("wall_time_s")
                cpu = data.get("machine", {}).get("cpu")
                records.append({"path": name, "wall_time_s": wall, "cpu": cpu})
                break
    return records


def problems(page: Path, text: str) -> list[str]:
    """What is wrong with the durations `text` (the page's) states, one line each."""
    where = page.relative_to(ROOT) if page.is_relative_to(ROOT) else page
    found = []
    for number, block in blocks(EXEMPT.sub("", text)):
        claims = LONG.findall(block)
        records = [r for r in _records(page, block) if r["wall_time_s"] is not None]
        if not claims and not (records and SECONDS.search(block)):
            continue
        said = ", ".join(" ".join(c) for c in claims)
        if not records:
            found.append(f"{where}:{number}: {said}: no record (a result.json or run.json) "
                         "gives this time; quote one's wall time with its machine, or drop it")
            continue
        for stated, unit in claims:
            scale = 60 if unit.lower().startswith("h") else 1
            if not any(_close(stated, r["wall_time_s"] / 60 / scale) for r in records):
                found.append(f"{where}:{number}: {stated} {unit} is not the wall time of "
                             + ", ".join(f"{r['path']} ({r['wall_time_s'] / 60:.1f} min)"
                                         for r in records))
        for stated, unit in SECONDS.findall(block):
            if not any(_close(stated, r["wall_time_s"]) for r in records):
                found.append(f"{where}:{number}: {stated} {unit} is not the wall time of "
                             + ", ".join(f"{r['path']} ({r['wall_time_s']} s)"
                                         for r in records))
        for r in records:
            if r["cpu"] and r["cpu"] not in block:
                found.append(f"{where}:{number}: names no machine: {r['path']} ran on "
                             f"{r['cpu']}")
    return found


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_time_a_page_states_is_a_record_s(page):
    found = problems(page, page.read_text())
    assert not found, "\n".join(found)


def test_contributing_keeps_the_test_times_in_one_marked_place():
    text = (ROOT / "CONTRIBUTING.md").read_text()
    regions = EXEMPT.findall(text)
    assert len(regions) == 1, "CONTRIBUTING.md: one <!-- test-times --> region"
    assert len(LONG.findall(regions[0])) >= 2, "the fast tier's and the suite's times"
    others = [p for p in PAGES if p.name != "CONTRIBUTING.md"
              and "test-times" in p.read_text()]
    assert not others, f"only CONTRIBUTING.md may hold hand-measured times: {others}"


# --- the check itself, on pages made up for it --------------------------------------------


@pytest.fixture
def result(tmp_path) -> Path:
    folder = tmp_path / "runs" / "mine"
    folder.mkdir(parents=True)
    (folder / "result.json").write_text(json.dumps(
        {"timing": {"wall_time_s": 1006.9}, "machine": {"cpu": "Some CPU", "cores": 2}}))
    return tmp_path / "page.md"


@pytest.mark.parametrize("text", [
    "The row took 17 min on Some CPU ([its result](runs/mine/result.json)).",
    "The row took 1006.9 s, 16.8 minutes, on Some CPU\n(runs/mine/result.json).",
    "- `mine` (runs/mine/result.json): `lgmd-sim benchmark mine`, 17 min on Some CPU",
    "No time stated here (runs/mine/result.json), false alarms 3 / min, 6 a minute.",
    "<!-- test-times -->about 2 minutes<!-- /test-times -->",
    "```text\n# python -m scripts.speed: CPU: Some CPU\nOne row: 6.6 min (target 15: met)\n```",
])
def test_a_time_its_record_gives_passes(result, text):
    assert problems(result, text) == []


@pytest.mark.parametrize(("text", "why"), [
    ("The row took 9 minutes on Some CPU ([its result](runs/mine/result.json)).",
     "9 minutes is not the wall time of runs/mine/result.json (16.8 min)"),
    ("The row took 1006 s on Some CPU (runs/mine/result.json).", "1006 s is not"),
    ("The row took 17 min ([its result](runs/mine/result.json)).", "names no machine"),
    ("```bash\nlgmd-sim benchmark mine --out runs   # about 10 min on 2 cores\n```",
     "10 min: no record"),
    ("Your own detector in five minutes.", "five minutes: no record"),
    ("The row took 17 min on Some CPU (runs/other/result.json).", "no record"),
])
def test_a_time_no_record_gives_fails(result, text, why):
    found = problems(result, text)
    assert len(found) == 1 and why in found[0], found
