"""docs/experiments/tools/own_detector_page.py: the own-detector pages' measured sections (the
checker in docs/guides/own-detector.md, the rows in docs/experiments/own-detector-rows.md) from run
folders (here small hand-made ones: the few files the sections read), each run's command beside its
rows, and runs that do not share their seeds or clips refused in one line."""

from __future__ import annotations

import csv
import importlib
import io
import json
from pathlib import Path

import pytest

# The research log's tools (docs/experiments/tools/): the slow tier, out of the edit loop.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[4]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


@pytest.fixture(scope="module")
def page():
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(TOOLS))  # it imports its sibling scripts
        yield importlib.import_module("own_detector_page")


def _run(folder: Path, config: dict, command: str, **files: str) -> Path:
    folder.mkdir()
    (folder / "run.json").write_text(json.dumps(
        {"config": config, "command": command, "wall_time_s": 120.0, "candidates": 4,
         "clips": 24}))
    for name, text in files.items():
        (folder / name.replace("_", ".")).write_text(text)
    return folder


def _csv(rows: list[dict[str, str]]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


CALIBRATION = {"task": "robot", "budget": 2, "search_seeds": [0, 2], "heldout_seeds": [100, 2],
               "resolution": "small"}
SUMMARY_HEAD = ("| detector | threshold | objective search / held-out |\n"
                "|---|---:|---:|\n")


def _calibration(folder: Path, detectors: list[str], **changes) -> Path:
    rows = "".join(f"| {d} | 0.900 | 0.{i}00 / 0.{i}50 |\n" for i, d in enumerate(detectors, 1))
    chosen = {"eta_lgmd:EtaLGMD": {"robot": {"from": "gabbiani", "params": {
        "alpha": 3.14159, "threshold": 0.9}}}}
    return _run(folder, {**CALIBRATION, "detectors": detectors, **changes},
                f"lgmd-sim calibrate --detectors {','.join(detectors)} --out {folder.name}",
                summary_md=SUMMARY_HEAD + rows,
                calibrated_json=json.dumps({"presets": chosen}))


def test_the_calibration_beside_the_built_ins(page, tmp_path):
    ours = _calibration(tmp_path / "eta", ["eta_lgmd:EtaLGMD", "eta_lgmd:EtaLGMD+imu"])
    theirs = _calibration(tmp_path / "built", ["lgmd1"])
    text = "\n".join(page.calibration_section(ours, theirs))
    assert "lgmd-sim calibrate --detectors eta_lgmd:EtaLGMD,eta_lgmd:EtaLGMD+imu --out eta" \
        in text and "lgmd-sim calibrate --detectors lgmd1 --out built" in text
    assert "Wall time 2 min for 4 candidates on 24 clips" in text
    assert "search seeds 0 to 1, held-out seeds 100 to 101" in text
    assert "| **eta_lgmd:EtaLGMD+imu** | 0.900 | 0.200 / 0.250 |" in text
    assert "| lgmd1 | 0.900 | 0.100 / 0.150 |" in text
    assert "| eta_lgmd:EtaLGMD/robot | gabbiani | alpha = 3.142, threshold = 0.9 |" in text
    other = _calibration(tmp_path / "other", ["lgmd1"], budget=16)
    with pytest.raises(SystemExit, match="not calibrations of the same clips and budget "
                                         r"\(they differ in budget\)"):
        page.calibration_section(ours, other)


CELL = {"scenario": "RoughTerrainObstacles", "jitter": "1.0", "tag": "", "side": "",
        "task": "goal", "episodes": "50", "success_rate": "0.5", "success_ci_low": "0.4",
        "success_ci_high": "0.6", "collision_rate": "0.1", "collision_ci_low": "0.05",
        "collision_ci_high": "0.2", "encounters": "", "avoidance_rate": "",
        "avoidance_ci_low": "", "avoidance_ci_high": "", "distance_vs_oracle": ""}


def _closed(folder: Path, cells: list[tuple[str, str, str, str]], seeds=(1000, 50),
            jitter=(0.0, 1.0)) -> Path:
    rows = [{**CELL, "controller": c, "model": m, "preset": p, "jitter": j}
            for c, m, p, j in cells]
    config = {"benchmark": "closed-loop", "seeds": list(seeds), "jitter": list(jitter),
              "resolution": "rl"}
    return _run(folder, config, f"lgmd-sim bench closed-loop --out {folder.name}",
                summary_csv=_csv(rows))


def test_the_closed_loop_rows_beside_the_built_ins(page, tmp_path):
    ours = _closed(tmp_path / "eta", [("oracle", "", "", "1.0"),
                                      ("reactive", "eta_lgmd:EtaLGMD", "robot", "1.0")])
    theirs = _closed(tmp_path / "built", [("oracle", "", "", "1.0"),
                                          ("reactive", "lgmd1", "robot", "1.0"),
                                          ("reactive", "lgmd1", "robot", "0.0")])
    lines = page.closed_loop_section([ours, theirs])
    assert "lgmd-sim bench closed-loop --out eta" in lines
    assert "lgmd-sim bench closed-loop --out built" in lines
    table = [line for line in lines if line.startswith("| ") and "episodes" not in line]
    # the example's cell first, then the others' at its jitter only, the Oracle once
    assert table == ["| **eta_lgmd:EtaLGMD/robot** | 50 | 50% [40, 60] | 10% [5, 20] |",
                     "| oracle | 50 | 50% [40, 60] | 10% [5, 20] |",
                     "| lgmd1/robot | 50 | 50% [40, 60] | 10% [5, 20] |"]
    assert lines[-2] == ("The example's best cell, eta_lgmd:EtaLGMD/robot: 50% [40, 60] success "
                         "and 10% [5, 20] collisions; the best built-in, lgmd1/robot: 50% "
                         "[40, 60] success and 10% [5, 20] collisions; the Oracle: 50% [40, "
                         "60] success and 10% [5, 20] collisions.")
    other = _closed(tmp_path / "other", [("reactive", "lgmd1", "robot", "1.0")],
                    seeds=(0, 50))
    with pytest.raises(SystemExit, match=r"the closed-loop runs ran different seeds"):
        page.closed_loop_section([ours, other])
    fewer = _closed(tmp_path / "fewer", [("reactive", "lgmd1", "robot", "0.0")], jitter=[0.0])
    with pytest.raises(SystemExit, match=r"fewer lacks jitter 1\.0 of .*eta"):
        page.closed_loop_section([ours, fewer])


OPEN_HEAD = ("| scenario | jitter | noise | detector | clips | SI | ROC AUC |\n"
             "|---|---:|---|---|---:|---:|---:|\n")


def _open(folder: Path, rows: str, clips=("HandheldApproach-j1-s0",)) -> Path:
    config = {"benchmark": "open-loop", "clips": list(clips), "resolution": "paper",
              "noise": []}
    return _run(folder, config, f"lgmd-sim bench open-loop --out {folder.name}",
                summary_md=OPEN_HEAD + rows)


def test_the_open_loop_rows_beside_the_built_ins(page, tmp_path):
    ours = _open(tmp_path / "eta", "| B | 1 | - | eta_lgmd:EtaLGMD/gabbiani | 8 | 0.5 | 0.6 |\n"
                                   "| A | 0 | - | eta_lgmd:EtaLGMD/gabbiani | 8 | 0.4 | - |\n")
    theirs = _open(tmp_path / "built", "| A | 0 | - | lgmd1/published | 8 | 0.3 | 0.9 |\n"
                                       "| A | 0 | gauss 0.001 | lgmd1/published | 8 | 0.2 | 0.1 |\n"
                                       "| B | 1 | - | lgmd1/published | 8 | 0.1 | 0.5 |\n"
                                       "| C | 1 | - | lgmd1/published | 8 | 0.1 | 0.2 |\n")
    lines = page.open_loop_section([ours, theirs])
    assert "lgmd-sim bench open-loop --out eta" in lines
    assert [line for line in lines if line.startswith("| ")][1:] == [
        "| A | 0 | - | **eta_lgmd:EtaLGMD/gabbiani** | 8 | 0.4 | - |",
        "| A | 0 | - | lgmd1/published | 8 | 0.3 | 0.9 |",
        "| B | 1 | - | **eta_lgmd:EtaLGMD/gabbiani** | 8 | 0.5 | 0.6 |",
        "| B | 1 | - | lgmd1/published | 8 | 0.1 | 0.5 |"]
    # per jitter level, each side's best mean over the scenarios it has one for
    assert lines[-2] == (
        "ROC AUC, mean over the scenarios that have one: at jitter 0, the example's best -, "
        "the best built-in lgmd1/published 0.90 (0.90 to 0.90 over 1 scenarios); at jitter "
        "1, the example's best eta_lgmd:EtaLGMD/gabbiani 0.60 (0.60 to 0.60 over 1 "
        "scenarios), the best built-in lgmd1/published 0.50 (0.50 to 0.50 over 1 scenarios).")
    other = _open(tmp_path / "other", "", clips=("HandheldApproach-j1-s8",))
    with pytest.raises(SystemExit, match="other lacks clips HandheldApproach-j1-s0 of"):
        page.open_loop_section([ours, other])


def test_the_checker_passes_the_example_and_fails_its_broken_copy(page):
    text = "\n".join(page.checker_section())
    assert "$ PYTHONPATH=examples lgmd-sim models --check eta_lgmd:EtaLGMD\n" \
           "eta_lgmd:EtaLGMD: passes 10 checks, skips 0" in text
    assert "$ PYTHONPATH=examples:tests/plugins lgmd-sim models --check " \
           "eta_broken:ResetEveryStream\n" in text
    assert ("lgmd-sim models: error: eta_broken:ResetEveryStream: reset: reset([1]) changed "
            "stream 0") in text
    assert text.count("Exit status 0.") == 1 and text.count("Exit status 2.") == 1


def test_a_section_replaces_the_text_between_its_markers_only(page):
    begin, end = page.markers("checker")
    text = f"before\n{begin}\nold\n{end}\nafter\n"
    assert page.replace(text, "checker", ["new"]) == f"before\n{begin}\n\nnew\n\n{end}\nafter\n"
    with pytest.raises(SystemExit, match="no calibration markers"):
        page.replace(text, "calibration", ["new"])
    # each section's page has its markers
    assert set(page.PAGES) == {"checker", "calibration", "open-loop", "closed-loop"}
    for section, path in page.PAGES.items():
        assert page.replace(path.read_text(), section, ["x"]).count("\nx\n") == 1


def test_the_image_rows_are_those_of_the_committed_benchmark_calibration(page):
    """The research log's +image calibration row and robot-image preset are the benchmark's
    own calibration of the example, a committed run folder (the other rows' runs were not
    committed: the page says so)."""
    run = ROOT / "docs" / "benchmark" / "runs" / "eta_lgmd_EtaLGMD-robot-image" / "calibration"
    lines = page.calibration_section(run)
    row = next(line for line in lines if line.startswith("| eta_lgmd:EtaLGMD+image |"))
    preset = next(line for line in lines if line.startswith("| eta_lgmd:EtaLGMD/robot-image |"))
    text = page.ROWS.read_text()
    assert page._bold(row) in text and preset in text
