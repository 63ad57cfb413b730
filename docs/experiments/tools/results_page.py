"""docs/experiments/results-log.md from benchmark runs: every table and figure made from
the runs' files, every sentence's figures computed from them, each run's command printed
beside its results. The figures go to docs/results/ (the page links them from beside it).

    .venv/bin/python docs/experiments/tools/results_page.py --open-loop runs/open-loop \
        --calibration runs/calibration-v3 --open-loop-front-ends runs/open-loop-compensated

Only these are typed by hand: the paper's numbers (its Tables 2 and 3, quoted with
their source), the targets, the descriptions of the measures, and commentary
(`Commentary`): a reading that no figure computes, printed as a quoted block that names
the runs it was written for, and only while the conditions it rests on hold on the runs
given; otherwise the page says that it was withdrawn, and why. The page and its figures
are written as one set (`lgmd_sim.core.fileio.write_files`): an interrupted run leaves the
previous page and figures whole.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shutil
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from stack_figures import stacked

from lgmd_sim.core.fileio import write_files
from lgmd_sim.world.params import RESOLUTIONS

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "docs" / "experiments" / "results-log.md"
FIGURES = ROOT / "docs" / "results"
#: The figures' folder as the page links it (relative to the page).
FIGURES_LINK = Path(os.path.relpath(FIGURES, OUT.parent)).as_posix()

#: The open-loop run's figures, one above the other: its clips, detection curves and noise.
OPEN_LOOP_FIGURE = "figures.png"

#: The paper's Table 2 (ISI, MpSI) and Table 3 (SI), quoted: (stream, kind, ISI, MpSI of
#: feedback, LGMD1, LGMD2, F(ONn), F(OFFp), SI of the same five).
PAPER = [
    ("Fig.4 (1)", "stationary", 0.9057, (1.5621, 1.5047, 1.6179, 1.5360, 1.5206),
     (0.8495, 0.7849, 0.7957, 0.8925, 0.8925)),
    ("Fig.4 (2)", "jitter", 0.6313, (1.5964, 1.0216, 1.0973, 1.1519, 1.1527),
     (0.9200, 0.0267, 0.0267, 0.0400, 0.0400)),
    ("Fig.5 (3)", "stationary", 0.9595, (1.7127, 1.6508, 1.7009, 1.7523, 1.7611),
     (0.9315, 0.9041, 0.8904, 0.9452, 0.9452)),
    ("Fig.5 (4)", "jitter", 0.7648, (1.5354, 1.0399, 1.1571, 1.2515, 1.2584),
     (0.8780, 0.0488, 0.0488, 0.2195, 0.2195)),
    ("Fig.6 (5)", "jitter", 0.6477, (1.6845, 1.0522, 1.1477, 1.2144, 1.2158),
     (0.9111, 0.0444, 0.0444, 0.1111, 0.1111)),
    ("Fig.6 (6)", "jitter", 0.6772, (1.5434, 1.0286, 1.1055, 1.2062, 1.2044),
     (0.9020, 0.0392, 0.0392, 0.1569, 0.1569)),
]
PAPER_MODELS = ("feedback", "lgmd1", "lgmd2", "f_on", "f_off")
#: Where the calibration's targets for the best detector come from.
TARGETS_SOURCE = "issue 9's (ego-motion compensation and honest calibration)"

#: A page's figures to write beside it: target -> the run's file to copy, or a function
#: that draws the figure into the path it is given.
Figures = dict[Path, "Path | Callable[[Path], None]"]


@dataclass(frozen=True)
class Commentary:
    """A reading of particular runs, typed by hand because no figure of theirs computes it.

    `block` prints it as a quoted block naming the runs it was written for, and only while
    every condition it rests on holds on the page's runs: a rerun whose data say otherwise
    gets the commentary withdrawn (saying which condition failed), not carried along."""

    written: str  #: YYYY-MM-DD; runs started later are not the ones it was written for
    commands: tuple[str, ...]  #: the commands of the runs it was written for
    text: str

    def block(self, runs: Sequence[Path], conditions: Sequence[tuple[str, bool]]
              ) -> list[str]:
        """The quoted block, or the notice of its withdrawal. `conditions`: (what the runs
        must show, phrased to follow "show that", whether they do)."""
        named = _and([f"`{m[1]}`" if (m := re.search(r"--out (\S+)", c)) else f"`{c}`"
                      for c in self.commands])
        rests_on = "; ".join(what for what, _ in conditions)
        failed = [what for what, holds in conditions if not holds]
        if failed:
            print(f"{Path(sys.argv[0]).name}: the commentary of {self.written} is withdrawn: "
                  f"the runs do not show that {'; '.join(failed)}", file=sys.stderr)
            return [f"> **Commentary withdrawn.** Written on {self.written} for the runs "
                    f"{named}, it holds only while the runs show that {rests_on}. The runs "
                    f"of this page do not show that {'; '.join(failed)}.", ""]
        head = (f"> **Commentary**, typed by hand on {self.written} for the runs {named} "
                "(their commands stand beside their results), printed because the runs of "
                f"this page show that {rests_on}")
        others = self._not_named(runs)
        if others:
            head += f". They are not the runs it was written for: {'; '.join(others)}"
        return [head + ".", ">", f"> {self.text}", ""]

    def _not_named(self, runs: Sequence[Path]) -> list[str]:
        out = []
        for run in runs:
            record = json.loads((run / "run.json").read_text())
            sessions = record.get("sessions") or [record]
            command = record.get("command") or sessions[0].get("command", "")
            if command not in self.commands:
                out.append(f"{run.name} ran `{command}`")
            later = [s["started"][:10] for s in sessions
                     if s.get("started", "")[:10] > self.written]
            if later:
                out.append(f"{run.name} ran on {_and(sorted(set(later)))}")
        return out


def _and(items: Sequence[str]) -> str:
    items = list(items)
    return ", ".join(items[:-1]) + " and " + items[-1] if len(items) > 1 else "".join(items)


#: The reading of the closed loop with the calibrated presets (`compensation_verdict`).
WHY_LATE = Commentary(
    written="2026-11-30",
    commands=(
        "lgmd-sim bench closed-loop --jitter 0,1,2 --seeds 50 --out runs/closed-loop "
        "--workers 2 --no-progress",
        "lgmd-sim bench closed-loop --jitter 1,2 --seeds 50 --models feedback/calibrated,"
        "feedback/calibrated-image,lgmd1/calibrated,lgmd1/calibrated-image,lgmd2/calibrated,"
        "lgmd2/calibrated-image --out runs/closed-loop-calibrated --workers 2 --no-progress",
        "lgmd-sim calibrate --budget 16 --detectors feedback,feedback-open-loop,lgmd1,lgmd2,"
        "f_on,feedback+image,feedback-open-loop+image,lgmd1+image,lgmd2+image,f_on+image "
        "--out runs/calibration-v3 --workers 1 --no-progress --resume --save-presets"),
    text=" ".join((
        "Why: the detectors with a front end alarm too late for the avoidance manoeuvre,",
        "while those without one that collide least alarm all the time and avoid by backing",
        "away, never reaching the goal. The calibration tuned them on the walker's clips,",
        "whose objective asks for an alarm late in the approach; the robot needs one earlier,",
        "and sees its own ground flow ([models-log.md](models-log.md), \"The robot: the ground's",
        "own flow\"). The robot's own calibration: \"The robot: its own calibration, two eyes,",
        "two tasks\" below.")))


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def _record(run: Path) -> dict:
    return json.loads((run / "run.json").read_text())


def _command(run: Path) -> str:
    return _record(run)["command"]


def _copy(run: Path, names: list[str], tag: str, figures: Figures) -> list[str]:
    """Add a run's figures to those to write under docs/results/<tag>/; their paths
    relative to the page."""
    out = []
    for name in names:
        if (run / name).is_file():
            figures[FIGURES / tag / name] = run / name
            out.append(f"{FIGURES_LINK}/{tag}/{name}")
    return out


def _resolution(value: str | list[int]) -> str:
    height, width = RESOLUTIONS[value] if isinstance(value, str) else value
    return f"{height} x {width}"


def seed_ranges(seeds: set[int]) -> str:
    """Seeds as spans of consecutive ones: "0 to 7 and 1000 to 1007"."""
    spans: list[list[int]] = []
    for s in sorted(seeds):
        if spans and s == spans[-1][1] + 1:
            spans[-1][1] = s
        else:
            spans.append([s, s])
    return _and([f"{a}" if a == b else f"{a} to {b}" for a, b in spans]) if spans else "none"


def _clip_seeds(run: Path) -> set[int]:
    """The episode seeds of an open-loop run's simulated clips (a dataset's have none)."""
    keys = _record(run)["config"]["clips"]
    return {int(m[1]) for k in keys if (m := re.search(r"-s(\d+)$", k))}


def _calibration_seeds(run: Path) -> set[int]:
    config = _record(run)["config"]
    return {s for key in ("search_seeds", "heldout_seeds")
            for s in range(config[key][0], config[key][0] + config[key][1])}


def _pct(x: str) -> float:
    return 100 * float(x)


def closed_loop_section(run: Path, title: str, tag: str, figures: Figures) -> list[str]:
    rows = _rows(run / "summary.csv")
    lines = [f"## {title}", "", "```bash", _command(run), "```", "",
             (run / "summary.md").read_text().strip(), ""]
    for scenario in sorted({r["scenario"] for r in rows}):
        for jitter in sorted({r["jitter"] for r in rows if r["scenario"] == scenario}, key=float):
            cell = [r for r in rows if r["scenario"] == scenario and r["jitter"] == jitter]
            lines.append(f"- **{scenario}, jitter {float(jitter):g}:** " + _verdict(cell))
    lines.append("")
    for fig in _copy(run, ["collisions_vs_jitter.png", "false_alarms_vs_collisions.png",
                           "trajectories.png"], tag, figures):
        lines += [f"![{fig}]({fig})", ""]
    return lines


def _verdict(cell: list[dict[str, str]]) -> str:
    """Plain sentences from one scenario and jitter level: the reactive detectors with the
    fewest collisions and with the most successes (and those tied with them within the 95%
    intervals), Oracle and Straight beside."""
    def name(r):
        return f"{r['model']}/{r['preset']}" if r["model"] else (r["tag"] or r["controller"])

    def rate(r, what):
        return (f"{_pct(r[what + '_rate']):.0f}% [{_pct(r[what + '_ci_low']):.0f}, "
                f"{_pct(r[what + '_ci_high']):.0f}]")

    reactive = [r for r in cell if r["controller"] == "reactive"]
    by = {r["controller"]: r for r in cell if not r["model"]}
    parts = []
    if reactive:
        safest = min(reactive, key=lambda r: float(r["collision_rate"]))
        ties = [name(r) for r in reactive if r is not safest
                and float(r["collision_ci_low"]) <= float(safest["collision_ci_high"])]
        parts.append(
            f"with ReactiveAvoid, the fewest collisions come with {name(safest)} "
            f"({rate(safest, 'collision')}; tied within the intervals: "
            f"{', '.join(ties) or 'none'}), which reaches the goal in "
            f"{_pct(safest['success_rate']):.0f}% at "
            f"{float(safest['false_alarms_per_min']):.1f} false alarms a minute.")
        best = max(reactive, key=lambda r: float(r["success_rate"]))
        parts.append(f"The most successes: {name(best)} ({rate(best, 'success')}, "
                     f"{_pct(best['collision_rate']):.0f}% collisions).")
    for ctrl in ("oracle", "straight"):
        if ctrl in by:
            parts.append(f"{ctrl.capitalize()}: {rate(by[ctrl], 'collision')} collisions, "
                         f"{rate(by[ctrl], 'success')} successes.")
    return " ".join(parts)


def compensation_verdict(runs: list[Path], calibration: Path | None = None) -> list[str]:
    """The closed-loop test of the compensation, over every reactive cell of the runs: at
    each jitter level, the compensated detector with the fewest collisions (then the
    fewest false alarms) against the uncompensated one chosen the same way; the target:
    at most half the collisions at no more false alarms per minute. Then when they alarm,
    against the Oracle, and `WHY_LATE` while the runs bear it out."""
    everything = [r for run in runs for r in _rows(run / "summary.csv")]
    cells = [r for r in everything if r["controller"] == "reactive" and float(r["jitter"]) > 0]
    out = ["### Compensated against uncompensated, closed loop", "",
           f"Over every ReactiveAvoid cell above ({_same_seeds(runs)}), at each "
           "jitter level: the detector with a front end with the fewest collisions (then the "
           "fewest false alarms) against the detector without one chosen the same way. "
           f"The target, {TARGETS_SOURCE}: at most half the collisions, at no more false "
           "alarms a minute.", ""]
    # per jitter level: the Oracle's cell, the best without a front end, all those with one
    levels = []
    for jitter in sorted({r["jitter"] for r in cells}, key=float):
        level = [r for r in cells if r["jitter"] == jitter]
        best = {}
        for compensated in (False, True):
            group = [r for r in level if _has_front_end(r["preset"]) == compensated]
            if group:
                best[compensated] = min(group, key=lambda r: (float(r["collision_rate"]),
                                                              float(r["false_alarms_per_min"])))
        if len(best) < 2:
            continue
        plain, comp = best[False], best[True]
        met = (float(comp["collision_rate"]) <= float(plain["collision_rate"]) / 2
               and float(comp["false_alarms_per_min"]) <= float(plain["false_alarms_per_min"]))
        out.append(
            f"- **jitter {float(jitter):g}:** {comp['model']}/{comp['preset']} "
            f"{_pct(comp['collision_rate']):.0f}% collisions, "
            f"{float(comp['false_alarms_per_min']):.1f} false alarms a minute, "
            f"{_pct(comp['success_rate']):.0f}% successes; {plain['model']}/{plain['preset']} "
            f"{_pct(plain['collision_rate']):.0f}%, "
            f"{float(plain['false_alarms_per_min']):.1f} a minute, "
            f"{_pct(plain['success_rate']):.0f}% successes. Target "
            f"{'met' if met else 'not met'}.")
        oracle = next((r for r in everything if r["controller"] == "oracle"
                       and r["jitter"] == jitter), None)
        levels.append((jitter, oracle, plain,
                       [r for r in level if _has_front_end(r["preset"])]))
    out.append("")
    out += [_when_they_alarm(*level) for level in levels]
    facts, conditions = _why_late_conditions(levels, everything, calibration)
    if facts:
        out += ["", facts]
    out += ["", *WHY_LATE.block([*runs, *([calibration] if calibration else [])], conditions)]
    return out


def _same_seeds(runs: list[Path]) -> str:
    seeds = {tuple(_record(run)["config"]["seeds"]) for run in runs}
    if len(seeds) == 1:
        (first, n), = seeds
        return f"every run on the same seeds, {first} to {first + n - 1}"
    return ("the runs' seeds differ: " + "; ".join(
        f"{run.name} {s[0]} to {s[0] + s[1] - 1}"
        for run in runs for s in [_record(run)["config"]["seeds"]]))


def _ttc(r: dict[str, str]) -> float | None:
    return float(r["median_first_alarm_ttc_s"]) if r["median_first_alarm_ttc_s"] else None


def _when_they_alarm(jitter: str, oracle: dict[str, str] | None, plain: dict[str, str],
                     comps: list[dict[str, str]]) -> str:
    """When the detectors with a front end alarm and how often they collide, against the
    Oracle; how often the one without a front end that collides least alarms."""
    ttc = [t for r in comps if (t := _ttc(r)) is not None]
    silent = len(comps) - len(ttc)
    text = (f"- **jitter {float(jitter):g}, when they alarm:** with a front end, the first "
            + (f"alarm comes a median {_span(ttc, '.2f')} s before the collision" if ttc
               else "alarm never comes")
            + (f" ({silent} never alarm)" if ttc and silent else ""))
    if oracle is not None and _ttc(oracle) is not None:
        text += f" (the Oracle's trigger: {_ttc(oracle):.2f} s)"
    text += (f", and {_span([_pct(r['collision_rate']) for r in comps], '.0f')}% of the "
             "episodes collide")
    if oracle is not None:
        text += f" (the Oracle's: {_pct(oracle['collision_rate']):.0f}%)"
    return (text + f"; without one, {plain['model']}/{plain['preset']} raises "
            f"{float(plain['false_alarms_per_min']):.1f} false alarms a minute (with a front "
            f"end: {_span([float(r['false_alarms_per_min']) for r in comps], '.1f')}), "
            f"reaches the goal in {_pct(plain['success_rate']):.0f}% and makes "
            f"{float(plain['mean_progress']):.2f} of the way to it (the Oracle: "
            + (f"{float(oracle['mean_progress']):.2f})." if oracle else "not run)."))


def _why_late_conditions(levels: list, everything: list[dict[str, str]],
                         calibration: Path | None) -> tuple[str, list[tuple[str, bool]]]:
    """The calibration's clips against the benchmark's (a sentence, when the calibration
    is given), and what `WHY_LATE` rests on, each checked at every jitter level."""
    def every(check: Callable[[dict | None, dict, list[dict]], bool]) -> bool:
        return bool(levels) and all(check(o, p, c) for _, o, p, c in levels)

    def later(o: dict | None, c: dict) -> bool:  # silent counts as late
        return o is not None and _ttc(o) is not None and (_ttc(c) is None or _ttc(c) < _ttc(o))

    conditions = [
        ("every detector with a front end alarms first later than the Oracle's trigger (a "
         "shorter median time to collision), or never",
         every(lambda o, p, cs: all(later(o, c) for c in cs))),
        ("every one of them collides more often than the Oracle, beyond the 95% intervals",
         every(lambda o, p, cs: o is not None and all(
             float(c["collision_ci_low"]) > float(o["collision_ci_high"]) for c in cs))),
        ("the detector without a front end that collides least raises more false alarms a "
         "minute than every one with a front end",
         every(lambda o, p, cs: all(float(p["false_alarms_per_min"])
                                    > float(c["false_alarms_per_min"]) for c in cs))),
        ("it never reaches the goal and makes at most a tenth of the Oracle's progress to it",
         every(lambda o, p, cs: o is not None and float(p["success_rate"]) == 0
               and float(p["mean_progress"]) <= float(o["mean_progress"]) / 10)),
    ]
    if calibration is None:
        return "", [*conditions, ("a calibration run (--calibration) holds the clips the "
                                  "presets were tuned on", False)]
    config = _record(calibration)["config"]
    tuned = list(dict.fromkeys(sc for groups in config["groups"].values() for sc, _ in groups))
    driven = sorted({r["scenario"] for r in everything})
    shared = [sc for sc in tuned if sc in driven]
    facts = (f"The calibrated presets were tuned on the calibration's clips of {_and(tuned)}"
             + (f", {_and(shared)} also driven here" if shared
                else f", none of them a scenario driven here ({_and(driven)})")
             + "; its objective asks a jitter clip for the first alarm in the last "
             f"{100 * config['late']:.0f}% of the approach.")
    return facts, [*conditions, ("the calibration's clips hold none of the scenarios driven "
                                 "here", not shared)]


def _has_front_end(preset: str) -> bool:
    return "+" in preset or any(f in preset.split("-") for f in ("image", "imu", "pose"))


def open_loop_section(run: Path, figures: Figures) -> list[str]:
    rows = _rows(run / "summary.csv")
    config = _record(run)["config"]
    clean = [r for r in rows if not r["noise"]]
    lines = ["## Open loop: the paper's Tables 2 and 3, simulated", "", "```bash",
             _command(run), "```", "",
             "The paper's streams (its Tables 2 and 3, quoted):", "",
             "| stream | kind | ISI | MpSI feedback / LGMD1 / LGMD2 / F(ONn) / F(OFFp) | "
             "SI feedback / LGMD1 / LGMD2 / F(ONn) / F(OFFp) |", "|---|---|---:|---|---|"]
    for stream, kind, isi, mpsi, si in PAPER:
        lines.append(f"| {stream} | {kind} | {isi:.4f} | "
                     f"{' / '.join(f'{v:.2f}' for v in mpsi)} | "
                     f"{' / '.join(f'{v:.2f}' for v in si)} |")
    lines += ["", "The same measures on the simulated clips (mean over the clips; SI counts a "
              "clip that never crosses the threshold as 1, and `crossed` is the share that "
              f"did; hits and false alarms with a {config['window']:g} s window; ROC AUC of "
              "the per-frame potential as a detector of an obstacle within "
              f"{config['horizon']:g} s of collision):", "",
              (run / "summary.md").read_text().strip(), ""]
    lines += _paper_sentences(clean)
    if (run / "noise.md").is_file():
        lines += ["", "### Noise (the paper's dataset d: stationary clips with Gaussian and "
                  "salt-and-pepper noise)", "", (run / "noise.md").read_text().strip(), ""]
    # the clips (a panel each), the detection curves and the noise, which the page shows
    # together: one figure, one file of the repository, not one a clip or a figure
    parts = [*sorted(run.glob("clip_*.png")),
             *(run / name for name in ("detection_curves.png", "noise.png")
               if (run / name).is_file())]
    if parts:
        figures[FIGURES / "open-loop" / OPEN_LOOP_FIGURE] = stacked(parts)
        fig = f"{FIGURES_LINK}/open-loop/{OPEN_LOOP_FIGURE}"
        lines += [f"![{fig}]({fig})", ""]
    return lines


def front_end_section(run: Path, tables: Path, calibration: Path | None,
                      figures: Figures) -> list[str]:
    """The open-loop benchmark of detectors with a front end, on the same scenarios; its
    seeds and frame size against those of the tables above (`tables`) and the calibration."""
    config = _record(run)["config"]
    seeds, used = _clip_seeds(run), {"the tables above": _clip_seeds(tables)}
    if calibration is not None:
        used["the calibration"] = _calibration_seeds(calibration)
    shared = {what: seeds & theirs for what, theirs in used.items() if seeds & theirs}
    size = _resolution(config["resolution"])
    if calibration is not None:
        theirs = _resolution(_record(calibration)["config"]["resolution"])
        size += " (as the calibration)" if theirs == size else f" (the calibration ran at {theirs})"
    noisy = any(r["noise"] for r in _rows(run / "summary.csv"))
    lines = ["## Open loop with front ends", "", "```bash", _command(run), "```", "",
             "The same measures as above for detectors that remove the camera's rotation "
             "(+image: fitted from the frames; calibrated-image: the calibrated presets "
             f"with it), on clips of seeds {seed_ranges(seeds)}, "
             + ("of which " + _and([f"{what} used {seed_ranges(s)}"
                                    for what, s in shared.items()])
                if shared else _unused_by(list(used)))
             + f", at {size}, "
             + ("with noise variants (the table: the clean clips)" if noisy
                else "without noise variants") + ":", "",
             (run / "summary.md").read_text().strip(), ""]
    for fig in _copy(run, ["detection_curves.png"], "open-loop-front-ends", figures):
        lines += [f"![{fig}]({fig})", ""]
    return lines


def _unused_by(others: list[str]) -> str:
    if len(others) == 1:
        return f"which {others[0]} did not use"
    return f"which neither {', '.join(others[:-1])} nor {others[-1]} used"


def _paper_sentences(clean: list[dict[str, str]]) -> list[str]:
    """Where the simulated clips agree with the paper's claims and where they do not."""
    def pick(kind_jitter):
        return [r for r in clean if kind_jitter(r["scenario"], float(r["jitter"]))]

    stationary = pick(lambda s, j: s == "StationaryApproach" and j == 0)
    shaken = pick(lambda s, j: s in ("HandheldApproach", "MutualApproach") and j > 0)
    out = []
    for label, group, paper_kind in (("stationary", stationary, "stationary"),
                                     ("jitter", shaken, "jitter")):
        for model in PAPER_MODELS:
            mine = [r for r in group if r["detector"].split("/")[0] == model]
            if not mine:
                continue
            k = PAPER_MODELS.index(model)
            paper_si = [p[4][k] for p in PAPER if p[1] == paper_kind]
            si = [float(r["si"]) for r in mine]
            crossed = [float(r["crossed"]) for r in mine]
            out.append(f"- {label} clips, {mine[0]['detector']}: SI {_span(si, '.2f')} here "
                       f"(crossed the threshold in {_span([100 * c for c in crossed], '.0f')}"
                       f"% of clips), {_span(paper_si, '.2f')} in the paper.")
    return out


def _span(values: list[float], fmt: str) -> str:
    lo, hi = format(min(values), fmt), format(max(values), fmt)
    return lo if lo == hi else f"{lo} to {hi}"


def calibration_section(run: Path, figures: Figures) -> list[str]:
    data = json.loads((run / "calibrated.json").read_text())
    lines = ["## Calibration", "", "```bash", _command(run), "```", "",
             "`--save-presets` writes the user's presets file; the shipped presets are this "
             f"run's through the release step, `docs/experiments/tools/ship_presets.py {run}`.", "",
             data["objective"], "",
             f"Each detector's best setting on the search seeds (the same budget of "
             f"{data['budget']} settings each), and the same setting on the held-out seeds "
             "(search / held-out):", "", (run / "summary.md").read_text().strip(), ""]
    config = json.loads((run / "run.json").read_text())["config"]
    counts = {kind: config["heldout_seeds"][1] * sum(len(j) for _, j in groups)
              for kind, groups in config["groups"].items()}
    lines += _attribution(data["presets"], counts)
    for fig in _copy(run, ["calibration.png"], "calibration", figures):
        lines += [f"![{fig}]({fig})", ""]
    return lines


def _attribution(presets: dict[str, dict[str, dict]], n: dict[str, int]) -> list[str]:
    """Which part does the work, from the held-out figures: the compensation (each model
    with and without the image front end), the feedback loop (the feedback LGMD against
    its open-loop control, tuned by the same search), the best detector against the
    targets. `n`: the held-out clips of each kind."""
    held = {f"{m}/{p}": v["heldout"] for m, ps in presets.items() for p, v in ps.items()}
    best = max(held, key=lambda k: held[k]["objective"])
    b = held[best]
    out = ["### Which part does the work (held-out seeds)", "",
           f"Held-out clips: {n['jitter']} jitter, {n['stationary']} stationary, "
           f"{n['near_miss']} near misses.", "",
           f"- **The best detector** is {best}: {100 * b['jitter']:.0f}% of the jitter clips "
           f"alarm late and before the collision (target 85% or more), "
           f"{100 * b['stationary']:.0f}% of the stationary clips before the collision "
           f"(target 95%), {100 * (1 - b['near_miss']):.0f}% of the near misses alarm "
           f"(target 10% or less). The targets are {TARGETS_SOURCE}."]
    for model in presets:
        plain, image = held.get(f"{model}/calibrated"), held.get(f"{model}/calibrated-image")
        if plain and image:
            out.append(f"- **Compensation, {model}:** objective {plain['objective']:.2f} "
                       f"without a front end, {image['objective']:.2f} with the rotation "
                       f"fitted from the images (jitter clips alarming late "
                       f"{100 * plain['jitter']:.0f}% -> {100 * image['jitter']:.0f}%).")
    for suffix, what in (("", "without a front end"), ("-image", "with the image front end")):
        loop = held.get(f"feedback/calibrated{suffix}")
        control = held.get(f"feedback/calibrated-open-loop{suffix}")
        if loop and control:
            out.append(f"- **The feedback loop, {what}:** objective {loop['objective']:.2f} "
                       f"against {control['objective']:.2f} for its open-loop control (the "
                       f"loop is credited with {loop['objective'] - control['objective']:+.2f}"
                       f"; near misses rejected {100 * loop['near_miss']:.0f}% against "
                       f"{100 * control['near_miss']:.0f}%).")
    return [*out, ""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    # the first closed-loop table (built-in defaults, seeds 1000-1049) gave way to the
    # benchmark's leaderboard: its run predates the LGMD1 steering-sign fix
    parser.add_argument("--closed-loop", type=Path)
    parser.add_argument("--open-loop", type=Path, required=True)
    parser.add_argument("--calibration", type=Path)
    # the closed loop with the calibrated presets (runs/closed-loop-calibrated) went the same
    # way: its ReactiveAvoid cells of LGMD1 ran before the steering-sign fix
    parser.add_argument("--closed-loop-calibrated", type=Path)
    parser.add_argument("--open-loop-front-ends", type=Path)
    args = parser.parse_args()
    figures: Figures = {}
    lines = ["# Results log", "",
             "The research log of the open-loop benchmark and the calibrations, whole; the "
             "findings in short: [findings](../findings.md). "
             "Made by `docs/experiments/tools/results_page.py` from the runs whose commands "
             "stand beside their results. Typed by hand: the paper's quoted numbers, the "
             "targets, the descriptions of the measures, and commentary, set apart as a "
             "quoted block that names the runs it was written for and is printed only while "
             "the conditions it states hold on the runs; every other sentence is computed from "
             "the runs. Regenerate it whenever a model or preset changes.", ""]
    if args.closed_loop:
        lines += closed_loop_section(args.closed_loop, "Closed loop: avoiding obstacles on "
                                     "rough ground", "closed-loop", figures)
    else:
        lines += ["How each detector drives the robot, every model on the same seeds: the "
                  "benchmark's [leaderboard](../leaderboard.md).", ""]
    lines += open_loop_section(args.open_loop, figures)
    if args.open_loop_front_ends:
        lines += front_end_section(args.open_loop_front_ends, args.open_loop,
                                   args.calibration, figures)
    if args.calibration:
        lines += calibration_section(args.calibration, figures)
    if args.closed_loop_calibrated:
        lines += closed_loop_section(args.closed_loop_calibrated, "Closed loop with the "
                                     "calibrated presets", "closed-loop-calibrated", figures)
        if args.closed_loop:
            lines += compensation_verdict([args.closed_loop, args.closed_loop_calibrated],
                                          args.calibration)
    text = "\n".join(lines).rstrip() + "\n"
    write_files({OUT: lambda tmp: tmp.write_text(text),
                 **{target: _copier(source) for target, source in figures.items()}})
    print(f"wrote {OUT.relative_to(ROOT)} and {FIGURES.relative_to(ROOT)}/")


def _copier(source: Path | Callable[[Path], None]) -> Callable[[Path], None]:
    """What writes a figure of `Figures` into the path it is given."""
    if isinstance(source, Path):
        return lambda tmp: shutil.copyfile(source, tmp)
    return source


if __name__ == "__main__":
    main()
