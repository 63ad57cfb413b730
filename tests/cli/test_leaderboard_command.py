"""The leaderboard ranks only what a result's episodes hold: scores and intervals recomputed
from the stored per-seed parts, every number range-checked, what goes into the Markdown
escaped, its inputs and output checked before anything is written (issue 49, items 1-3,
11 and 19). Each case edits a copy of a shipped result, as a user could."""

from __future__ import annotations

import json
import math
import os
import re
import shlex
import shutil
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from lgmd_sim import cli

ROOT = Path(__file__).resolve().parents[2]
LEADERBOARD = ROOT / "docs" / "leaderboard.md"

LEADERBOARD_V1 = ROOT / "docs" / "benchmark" / "leaderboard-v1.md"


RUNS = Path(__file__).resolve().parents[2] / "docs" / "benchmark" / "runs"


def _copy(tmp_path: Path, name: str, edit: Callable[[dict], None] | None = None,
          as_text: Callable[[str], str] | None = None) -> Path:
    """A copy of the shipped result `name`, edited (as a JSON value, then as text)."""
    result = json.loads((RUNS / name / "result.json").read_text())
    if edit:
        edit(result)
    text = json.dumps(result)
    file = tmp_path / name / "result.json"
    file.parent.mkdir(parents=True)
    file.write_text(as_text(text) if as_text else text)
    return file


def _board(tmp_path: Path, capsys, *results: Path | str, out: str | None = None
           ) -> tuple[int, str, Path]:
    """`lgmd-sim leaderboard` over `results` (v1 rows) into tmp_path/board/board.md (or
    `out`): its exit code, its stderr, the table's path."""
    table = tmp_path / "board" / "board.md" if out is None else Path(out)
    code = cli.main(["leaderboard", *map(str, results), "--out", str(table), "--protocol",
                     "v1"])
    return code, capsys.readouterr().err.strip(), table


def _set(path: str, value) -> Callable[[dict], None]:
    def edit(result: dict) -> None:
        *parents, key = path.split(".")
        node = result
        for p in parents:
            node = node[int(p)] if isinstance(node, list) else node[p]
        node[int(key) if isinstance(node, list) else key] = value
    return edit


def _zero_parts(result: dict) -> None:
    for track in ("goal", "arena"):
        result["parts"][track]["sums"] = [[0.0, 0.0] for _ in result["parts"][track]["sums"]]


@pytest.mark.parametrize("edit, field", [
    (_set("scores.overall", 0.99), "scores.overall"),
    (_set("scores.overall", 57), "scores.overall"),
    (_set("scores.goal", -3), "scores.goal"),
    (_set("scores.arena", math.inf), "scores.arena"),
    (_set("scores.arena", math.nan), "scores.arena"),
    (_set("intervals.overall", [0.0, 1.0]), "intervals.overall"),
    (_set("parts.goal.sums.0.0", 3.5), "parts.goal.sums[0]"),  # 3.5 of 3 episodes' SPL
    (_set("parts.arena.sums.3.1", 4.0), "parts.arena.sums[3]"),  # a 4th episode of 3 levels
    (_zero_parts, "parts.goal.sums[0]"),  # parts summing to zero (a NumPy warning and "=2")
    (_set("parts.goal.seeds.0", 1), "parts.goal.seeds"),
    (_set("metrics.goal.1.score", 0.9), "metrics.goal"),
    (_set("metrics.goal.1.success_rate", 1.5), "metrics.goal.1.success_rate"),
    (_set("metrics.goal.1.false_alarms_per_min", "many"), "metrics.goal.1.false_alarms_per_min"),
    (_set("metrics.arena", {"1": {"score": 0.5}}), "metrics.arena"),
    (_set("timing.wall_time_s", -1e12), "timing.wall_time_s"),
    (_set("entry.label", "oracle"), "entry.label"),  # a duplicate under another label
])
def test_a_result_claiming_what_its_parts_do_not_hold_is_refused_naming_the_field(
        tmp_path, capsys, edit, field):
    forged = _copy(tmp_path, "straight", edit)
    code, err, table = _board(tmp_path, capsys, forged, RUNS / "oracle")
    assert code == 2 and len(err.splitlines()) == 1, err
    assert str(forged) in err and field in err and "not ranked" in err, err
    assert not table.parent.exists()


def test_a_detector_s_detection_metrics_must_be_its_parts(tmp_path, capsys):
    forged = _copy(tmp_path, "lgmd1-robot-image", _set("metrics.detection.hit_rate", 1.0))
    code, err, _ = _board(tmp_path, capsys, forged)
    assert code == 2 and "metrics.detection.hit_rate" in err, err


def test_the_shipped_results_pass_as_they_are(tmp_path, capsys):
    code, err, table = _board(tmp_path, capsys, RUNS / "straight", RUNS / "oracle")
    assert code == 0, err
    assert "| 1 | `oracle` | 0.75 [0.72, 0.77]" in table.read_text()


def _policy_named(name: str) -> Callable[[dict], None]:
    """A policy result as if benchmarked from a folder called `name` (as its label says)."""
    def edit(result: dict) -> None:
        result["entry"]["policy"] = f"/somewhere/{name}"
        result["entry"]["label"] = f"policy:{name}"
    return edit


def _table_rows(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("| ")]


def test_names_commands_and_machines_cannot_inject_into_the_table(tmp_path, capsys):
    evil = "evil|pol`<img src=x onerror=alert(1)>"
    fake_row = "a\n| 1 | `fake` | 1.00 |"

    def command(result: dict) -> None:
        result["command"] = "lgmd-sim benchmark x\n# Owned <script>alert(1)</script>"
        result["machine"]["cpu"] = "evil|<b>x</b>[link](http://x)"

    first = _copy(tmp_path / "a", "policy_feedback-student", _policy_named(evil))
    second = _copy(tmp_path / "b", "policy_feedback-student", _policy_named(fake_row))
    third = _copy(tmp_path, "straight", command)
    code, err, table = _board(tmp_path, capsys, first, second, third)
    assert code == 0, err
    text = table.read_text()
    rows = _table_rows(text)
    assert len(rows) == 1 + 3  # the heading, one row per result
    # every row has the table's 12 cell borders: no pipe of a name splits a cell
    assert all(len(re.findall(r"(?<!\\)\|", row)) == 12 for row in rows), rows
    assert "``policy:evil\\|pol`<img src=x onerror=alert(1)>``" in text
    assert "``policy:a\\n\\| 1 \\| `fake` \\| 1.00 \\|``" in text
    # outside code spans, no HTML, no heading, no link
    outside = re.sub(r"(`+).*?\1", "", text)
    assert "<" not in outside
    assert re.findall(r"(?<!\\)\]\(", outside) == ["]("]  # the figure's, alone
    assert [line for line in text.splitlines() if line.startswith("#")] == ["# Leaderboard"]
    assert "evil\\|&lt;b&gt;x&lt;/b&gt;\\[link\\](http://x)" in text


def test_a_leaderboard_of_policies_alone_has_no_arena_column(tmp_path, capsys):
    # a StopIteration traceback, and an empty output folder left
    code, err, table = _board(tmp_path, capsys, RUNS / "policy_feedback-student",
                              RUNS / "policy_student-feedback-h4-memory-best")
    assert code == 0, err
    assert table.is_file() and table.with_suffix(".png").is_file()


@pytest.mark.parametrize("out", ["b.png", "", "board"])
def test_an_out_that_is_no_markdown_file_is_refused_before_anything(tmp_path, capsys,
                                                                    monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "board").mkdir()
    code, err, _ = _board(tmp_path, capsys, RUNS / "straight", out=out)
    assert code == 2 and "--out" in err and "FILE.md" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["board"]


@pytest.mark.parametrize("text, why", [
    (lambda t: "[" * 100_000 + "]" * 100_000, "nested too deeply"),
    (lambda t: t.replace('"intervals"', '"intervalz"'), "intervals"),
    (lambda t: t.replace('"goal": {"0": {', '"goal": {"0": {"x": 1, ', 1)
     .replace('"success_rate": 0.0', '"success_rate": "none"', 1), "success_rate"),
])
def test_a_malformed_result_is_one_line(tmp_path, capsys, text, why):
    bad = _copy(tmp_path, "straight", as_text=text)
    code, err, table = _board(tmp_path, capsys, bad)
    assert code == 2 and len(err.splitlines()) == 1 and why in err, err
    assert not table.parent.exists()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_named_result_json_is_refused_without_waiting(tmp_path, capsys):
    fifo = tmp_path / "result.json"
    os.mkfifo(fifo)
    start = time.perf_counter()
    code, err, _ = _board(tmp_path, capsys, fifo)
    assert code == 2 and "not a regular file" in err and time.perf_counter() - start < 10


def test_a_file_that_is_no_result_says_what_to_give(tmp_path, capsys):
    board = tmp_path / "board.md"
    shutil.copy(RUNS.parents[1] / "leaderboard.md", board)
    code, err, _ = _board(tmp_path, capsys, board)
    assert code == 2 and str(board) in err and "result.json" in err, err
    assert "again" not in err


@pytest.mark.parametrize(("page", "version"), [(LEADERBOARD, "v2"),
                                               (LEADERBOARD_V1, "v1")],
                         ids=["leaderboard", "leaderboard-v1"])
def test_the_leaderboard_page_is_what_its_results_make_now(tmp_path, page, version):
    """docs/leaderboard.md (protocol v2) and v1's are `lgmd-sim leaderboard` over the result
    files they name, as the code ranks them today."""
    from lgmd_sim.benchmark import protocol
    from lgmd_sim.benchmark.leaderboard import leaderboard

    text = page.read_text()
    names = re.findall(r"^- `[^`]+` \(([^)]+/result\.json)\)", text, re.M)
    assert names and all((ROOT / n).is_file() for n in names), names
    out = tmp_path / page.name
    leaderboard([ROOT / n for n in names], out, protocol.load(version))
    made = out.read_text().replace(str(ROOT) + "/", "")
    where = str(page.relative_to(ROOT))
    assert made == text, (f"{where} is stale: " + shlex.join(
        ["lgmd-sim", "leaderboard", *names, "--protocol", version, "--out", where]))
