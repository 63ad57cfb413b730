"""The measured sections of the own-detector pages: the checker's output on the worked
example and on a broken variant of it (docs/guides/own-detector.md), the example's
calibration, and its open-loop and closed-loop rows beside the built-ins'
(docs/experiments/own-detector-rows.md), each run's command beside its results. Each
section replaces the text between its markers (`<!-- own-detector: SECTION made by ... -->`
... `<!-- own-detector: SECTION end -->`, SECTION one of checker, calibration, open-loop,
closed-loop) on its page (PAGES); a section whose runs are not given keeps what is there,
and the rest of the pages stays as written.

    .venv/bin/python docs/experiments/tools/own_detector_page.py \
        --calibration runs/calibration-eta --beside runs/calibration-robot \
        --open-loop runs/open-loop-eta runs/open-loop \
        --closed-loop runs/closed-loop-eta runs/closed-loop-robot

The checker section is always remade: it runs `lgmd-sim models --check` on the example,
examples/eta_lgmd.py, and on tests/plugins/eta_broken.py. The runs, with examples on the
path (the calibration is the built-ins' robot calibration's task, budget and seeds; its
presets, saved, are what the closed loop runs; the open-loop run beside is that of
docs/experiments/results-log.md, all the built-ins at their default presets):

    export PYTHONPATH=examples LGMD_SIM_DATA_DIR=runs/eta-presets  # presets saved there
    lgmd-sim calibrate --task robot --budget 16 --seeds 6 --save-presets \
        --detectors eta_lgmd:EtaLGMD,eta_lgmd:EtaLGMD+imu,eta_lgmd:EtaLGMD+image \
        --out runs/calibration-eta --workers 2 --no-progress
    lgmd-sim bench closed-loop --scenarios RoughTerrainObstacles,ArenaRoam --jitter 1 \
        --seeds 50 --controllers oracle,reactive --out runs/closed-loop-eta \
        --models eta_lgmd:EtaLGMD/robot,eta_lgmd:EtaLGMD/robot-imu,eta_lgmd:EtaLGMD/robot-image
    lgmd-sim bench open-loop --models eta_lgmd:EtaLGMD,eta_lgmd:EtaLGMD/gabbiani+image \
        --out runs/open-loop-eta --workers 2 --no-progress
    lgmd-sim bench open-loop --out runs/open-loop --workers 2 --no-progress
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from results_page import ROOT, _command, _record, _rows, seed_ranges
from robot_page import _cell, _cell_id, _pct, _wall

from lgmd_sim.core.fileio import write_files

GUIDE = ROOT / "docs" / "guides" / "own-detector.md"
ROWS = ROOT / "docs" / "experiments" / "own-detector-rows.md"
#: The page that holds each section: the checker in the user's guide, the measured rows in
#: the research log.
PAGES = {"checker": GUIDE, "calibration": ROWS, "open-loop": ROWS, "closed-loop": ROWS}
#: The checker's subjects, each with the folders that make it importable (PYTHONPATH): the
#: worked example, and the same broken on purpose (a test plug-in built on the example).
EXAMPLE = "eta_lgmd:EtaLGMD"
BROKEN = "eta_broken:ResetEveryStream"
SUBJECTS = ((EXAMPLE, ("examples",)), (BROKEN, ("examples", "tests/plugins")))
#: What a bench's runs must share for their rows to stand in one table: the same values,
#: and (the list) every one the example's run ran.
SAME = {"closed-loop": ("seeds", "resolution"), "open-loop": ("resolution",)}
COVERED = {"closed-loop": "jitter", "open-loop": "clips"}


def markers(section: str) -> tuple[str, str]:
    return (f"<!-- own-detector: {section} made by docs/experiments/tools/own_detector_page.py -->",
            f"<!-- own-detector: {section} end -->")


def replace(page: str, section: str, lines: Sequence[str]) -> str:
    """`page` with the text between `section`'s markers replaced by `lines`."""
    begin, end = markers(section)
    start, stop = page.find(begin), page.find(end)
    if start < 0 or stop < start:
        raise SystemExit(f"own_detector_page.py: the page has no {section} markers ({begin})")
    return page[:start + len(begin)] + "\n\n" + "\n".join(lines).strip() + "\n\n" + page[stop:]


def _fail(message: str) -> None:
    raise SystemExit(f"own_detector_page.py: {message}")


# --- the checker ---------------------------------------------------------------------------


def check(spec: str, path: Sequence[str]) -> tuple[str, str, int]:
    """`PYTHONPATH=PATH lgmd-sim models --check SPEC`, run in the checkout: (the command,
    what it printed, its exit status)."""
    command = f"PYTHONPATH={':'.join(path)} lgmd-sim models --check {spec}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(path)}
    done = subprocess.run([sys.executable, "-m", "lgmd_sim.cli", "models", "--check", spec],
                          cwd=ROOT, env=env, capture_output=True, text=True)
    return command, (done.stdout + done.stderr).strip(), done.returncode


def checker_section() -> list[str]:
    """The checker on the example (it passes) and on its broken variant (it fails)."""
    lines = ["`lgmd-sim models --check` on the example, and on a copy of it broken on "
             "purpose, [`tests/plugins/eta_broken.py`](../../tests/plugins/eta_broken.py), "
             "whose `reset_streams` resets every stream instead of the streams it is given:",
             ""]
    for spec, path in SUBJECTS:
        command, output, status = check(spec, path)
        lines += ["```console", f"$ {command}", output, "```", "", f"Exit status {status}.",
                  ""]
    return lines


# --- the calibration -----------------------------------------------------------------------


def _table(run: Path) -> tuple[list[str], list[str]]:
    """The header (two lines) and the rows of a run's summary.md table."""
    lines = [line for line in (run / "summary.md").read_text().splitlines()
             if line.startswith("|")]
    return lines[:2], lines[2:]


def _config(run: Path, leave_out: Sequence[str] = ()) -> dict:
    config = _record(run)["config"]
    return {k: v for k, v in config.items() if k not in leave_out}


def _bold(row: str, column: int = 0) -> str:
    """A markdown table row with one cell in bold: the example's rows."""
    cells = _cells(row)
    cells[column] = f"**{cells[column]}**"
    return "| " + " | ".join(cells) + " |"


def _params(values: dict) -> str:
    return ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}"
                     for k, v in values.items())


def _seeds(first_count: Sequence[int]) -> str:
    first, count = first_count
    return seed_ranges(set(range(first, first + count)))


def calibration_section(run: Path, beside: Path | None = None) -> list[str]:
    """The example's calibration: its command, wall time, summary rows and chosen values;
    with `beside` (the built-ins' calibration of the same task, budget and seeds) their
    rows below the example's, in bold, in one table."""
    record = _record(run)
    lines = ["The example's calibration:", "", "```bash", *_session_commands(run), "```"]
    if beside is not None:
        ours, theirs = _config(run, ["detectors"]), _config(beside, ["detectors"])
        differ = sorted(k for k in ours.keys() | theirs.keys() if ours.get(k) != theirs.get(k))
        if differ:
            _fail(f"{run} and {beside} are not calibrations of the same clips and budget "
                  f"(they differ in {', '.join(differ)})")
        lines += ["", "beside the built-ins' calibration of the same task, budget and seeds:",
                  "", "```bash", *_session_commands(beside), "```"]
    config = record["config"]
    search, held = config["search_seeds"], config["heldout_seeds"]
    lines += ["", f"Wall time {_wall(run)} for {record.get('candidates', '?')} candidates on "
              f"{record.get('clips', '?')} clips ({config['task']} task, budget "
              f"{config['budget']}, search seeds {_seeds(search)}, held-out seeds "
              f"{_seeds(held)}). Each detector's best "
              "setting on the search seeds, and the same setting on the held-out seeds "
              "(search / held-out)" + (", the example's in bold:" if beside else ":"), ""]
    head, rows = _table(run)
    lines += [*head, *(_bold(r) if beside else r for r in rows)]
    if beside is not None:
        theirs_head, theirs_rows = _table(beside)
        if theirs_head != head:
            _fail(f"the summaries of {run} and {beside} have other columns")
        lines += theirs_rows
    lines += ["", "The values chosen (`calibrated.json`; `--save-presets` makes them the "
              "presets below):", "", "| preset | from | parameters |", "|---|---|---|"]
    presets = json.loads((run / "calibrated.json").read_text())["presets"]
    for model, chosen in presets.items():
        for name, entry in chosen.items():
            lines.append(f"| {model}/{name} | {entry['from']} | {_params(entry['params'])} |")
    return [*lines, ""]


# --- the benchmarks ------------------------------------------------------------------------


def _same(runs: Sequence[Path], bench: str) -> None:
    """Refuse runs that are not of `bench`, or ran other seeds or frames, or lack some of
    the example's (the first run's) jitter levels or clips."""
    for run in runs:
        if _config(run).get("benchmark") != bench:
            _fail(f"{run} is not a {bench} run")
    for key in SAME[bench]:
        values = {json.dumps(_config(r).get(key)) for r in runs}
        if len(values) > 1:
            _fail(f"the {bench} runs ran different {key} ({', '.join(sorted(values))})")
    key = COVERED[bench]
    for run in runs[1:]:
        lacks = [v for v in _config(runs[0])[key] if v not in _config(run)[key]]
        if lacks:
            _fail(f"{run} lacks {key} {', '.join(map(str, lacks))} of {runs[0]}")


def _session_commands(run: Path) -> list[str]:
    """The commands of the run's sessions that did more than resume the one before (the
    calibration's second session saved its presets), in order."""
    out: list[str] = []
    for session in _record(run).get("sessions") or [{"command": _command(run)}]:
        command = session["command"]
        if not out or command.replace(" --resume", "") != out[-1].replace(" --resume", ""):
            out.append(command)
    return out


def _commands(runs: Sequence[Path]) -> list[str]:
    lines = []
    for run in runs:
        lines += ["```bash", *_session_commands(run), "```", "", f"Wall time {_wall(run)}.", ""]
    return lines


def closed_loop_section(runs: Sequence[Path]) -> list[str]:
    """The example's closed-loop cells (the first run's ReactiveAvoid cells) beside the
    other runs' cells of the same scenarios and jitter levels (the built-ins, the Oracle
    and Straight): per task and jitter, success and collisions on the goal task, the
    encounters avoided and the distance against the Oracle's in the arena."""
    _same(runs, "closed-loop")
    example, *others = runs
    ours = [r for r in _rows(example / "summary.csv") if r["controller"] == "reactive"]
    cells = {(r["scenario"], r["jitter"]) for r in ours}
    rows, seen = list(ours), {_cell_id(r) for r in ours}
    for run in others:
        for r in _rows(run / "summary.csv"):
            if (r["scenario"], r["jitter"]) in cells and _cell_id(r) not in seen:
                rows.append(r)
                seen.add(_cell_id(r))
    mine = {_cell_id(r) for r in ours}
    lines = ["### Closed loop", "", "The example driving ReactiveAvoid (in bold), beside the "
             "built-ins and the Oracle on the same seeds:", "", *_commands(runs)]
    for scenario, jitter in sorted(cells):
        group = [r for r in rows if (r["scenario"], r["jitter"]) == (scenario, jitter)]
        goal = group[0]["task"] == "goal"
        lines += [f"**{scenario}, jitter {float(jitter):g}**", "",
                  "| cell | episodes | " + ("success % [95% CI] | collisions % [95% CI] |"
                                           if goal else "encounters | avoided % [95% CI] | "
                                           "distance vs Oracle |"),
                  "|---|---:|---:|---:|" + ("" if goal else "---:|")]
        for r in group:
            name = f"**{_cell(r)}**" if _cell_id(r) in mine else _cell(r)
            measures = ([_pct(r, "success"), _pct(r, "collision")] if goal else
                        [r["encounters"], _pct(r, "avoidance"),
                         f"{float(r['distance_vs_oracle']):.2f}" if r["distance_vs_oracle"]
                         else "-"])
            lines.append(f"| {name} | {r['episodes']} | " + " | ".join(measures) + " |")
        lines += ["", _closed_loop_reading(group, mine, goal), ""]
    return lines


def _closed_loop_reading(group: list[dict[str, str]], mine: set[tuple[str, ...]],
                         goal: bool) -> str:
    """The example's best cell against the Oracle and the best built-in ReactiveAvoid
    cell of the table, in one sentence: on the goal task by successes (then fewer
    collisions), in the arena by encounters avoided."""
    def score(r: dict[str, str]) -> tuple[float, ...]:
        return ((float(r["success_rate"]), -float(r["collision_rate"])) if goal
                else (float(r["avoidance_rate"]),))

    def said(r: dict[str, str]) -> str:
        return (f"{_pct(r, 'success')} success and {_pct(r, 'collision')} collisions" if goal
                else f"{_pct(r, 'avoidance')} of its encounters avoided")

    ours = max((r for r in group if _cell_id(r) in mine), key=score)
    builtin = max((r for r in group if _cell_id(r) not in mine and r["controller"] == "reactive"),
                  key=score, default=None)
    oracle = next((r for r in group if r["controller"] == "oracle"), None)
    text = f"The example's best cell, {_cell(ours)}: {said(ours)}"
    if builtin is not None:
        text += f"; the best built-in, {_cell(builtin)}: {said(builtin)}"
    if oracle is not None:
        text += f"; the Oracle: {said(oracle)}"
    return text + "."


def _cells(row: str) -> list[str]:
    return [c.strip() for c in row.strip().strip("|").split("|")]


def open_loop_section(runs: Sequence[Path]) -> list[str]:
    """The example's open-loop rows (the first run's) beside the other runs' rows of its
    scenarios and jitter levels, from the runs' summary.md (the columns of summary.csv),
    the noisy variants left out: each scenario and jitter level's rows together, the
    example's first."""
    _same(runs, "open-loop")
    example, *others = runs
    head, ours = _table(example)
    at = {name: i for i, name in enumerate(_cells(head[0]))}

    def get(row: str, name: str) -> str:
        return _cells(row)[at[name]]

    cells = {(get(r, "scenario"), get(r, "jitter")) for r in ours}
    rows = [(0, r) for r in ours]
    for run in others:
        theirs_head, theirs = _table(run)
        if theirs_head != head:
            _fail(f"the summaries of {example} and {run} have other columns")
        known = {get(r, "detector") for _, r in rows}
        rows += [(1, r) for r in theirs if get(r, "detector") not in known
                 and (get(r, "scenario"), get(r, "jitter")) in cells]
    clean = sorted(((k, r) for k, r in rows if get(r, "noise") == "-"),
                   key=lambda kr: (get(kr[1], "scenario"), float(get(kr[1], "jitter")),
                                   kr[0], get(kr[1], "detector")))
    return ["### Open loop", "", "The example (in bold) beside the built-ins on the same "
            "clips (the measures of the open-loop tables of [the results log](results-log.md); "
            "the noisy variants left out):", "", *_commands(runs), *head,
            *(_bold(r, at["detector"]) if k == 0 else r for k, r in clean), "",
            _open_loop_reading([(k, get(r, "jitter"), get(r, "detector"), get(r, "ROC AUC"))
                                for k, r in clean]), ""]


def _open_loop_reading(rows: list[tuple[int, str, str, str]]) -> str:
    """Per jitter level, the ROC AUC over the scenarios that have one, of the example's
    best detector and of the best built-in: mean and range."""
    parts = []
    for jitter in sorted({j for _, j, _, _ in rows}, key=float):
        best = {}
        for mine in (0, 1):
            aucs: dict[str, list[float]] = {}
            for k, j, detector, auc in rows:
                if k == mine and j == jitter and auc != "-":
                    aucs.setdefault(detector, []).append(float(auc))
            if not aucs:
                best[mine] = "-"
                continue
            name, values = max(aucs.items(), key=lambda kv: sum(kv[1]) / len(kv[1]))
            best[mine] = (f"{name} {sum(values) / len(values):.2f} ({min(values):.2f} to "
                          f"{max(values):.2f} over {len(values)} scenarios)")
        parts.append(f"at jitter {float(jitter):g}, the example's best {best[0]}, the best "
                     f"built-in {best[1]}")
    return "ROC AUC, mean over the scenarios that have one: " + "; ".join(parts) + "."


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calibration", type=Path,
                        help="a calibration run of the example's detectors")
    parser.add_argument("--beside", type=Path, help="the built-ins' calibration run of the "
                        "same task, budget and seeds")
    parser.add_argument("--open-loop", type=Path, nargs="+", default=[],
                        help="open-loop runs on the same clips: the example's first")
    parser.add_argument("--closed-loop", type=Path, nargs="+", default=[],
                        help="closed-loop runs on the same seeds: the example's first")
    args = parser.parse_args()
    if args.beside and not args.calibration:
        _fail("--beside needs --calibration")
    sections = {"checker": checker_section}
    if args.calibration:
        sections["calibration"] = lambda: calibration_section(args.calibration, args.beside)
    if args.open_loop:
        sections["open-loop"] = lambda: open_loop_section(args.open_loop)
    if args.closed_loop:
        sections["closed-loop"] = lambda: closed_loop_section(args.closed_loop)
    pages: dict[Path, str] = {}
    for section, make in sections.items():
        path = PAGES[section]
        pages[path] = replace(pages.get(path) or path.read_text(), section, make())
    # every page written only once every section is made: a failed run leaves none half done
    write_files({path: lambda tmp, text=text: tmp.write_text(text)
                 for path, text in pages.items()})
    for path in pages:
        print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
