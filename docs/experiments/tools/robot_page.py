"""The robot's section of docs/experiments/results-log.md, from its runs: how early the
manoeuvre must start, the robot calibration, and the closed-loop benchmark of both tasks
with the targets and which part does the work. Every table, figure and sentence's figures
come from the runs' files, each run's command beside its results; the section replaces
the one between the markers (or is appended), the rest of the page stays as
`docs/experiments/tools/results_page.py` made it.

    .venv/bin/python docs/experiments/tools/robot_page.py --oracle-window runs/oracle-window \
        --calibration runs/calibration-robot \
        --closed-loop runs/closed-loop-robot runs/closed-loop-robot-j1 \
        runs/closed-loop-robot-j1-parts
"""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from oracle_window import COLLISIONS, SUCCESS, horizon, window
from results_page import FIGURES, FIGURES_LINK, OUT, ROOT, Figures, _command, _copier, _copy, _rows
from stack_figures import stacked

from lgmd_sim.benchmark import encounters
from lgmd_sim.calibration import robot
from lgmd_sim.calibration.clips import specs
from lgmd_sim.calibration.objective import THRESHOLDS, unpack_hits
from lgmd_sim.calibration.tasks import preset_name
from lgmd_sim.core.fileio import write_files

BEGIN = "<!-- robot: made by docs/experiments/tools/robot_page.py from the runs named below -->"
END = "<!-- robot: end -->"
#: The robot issue's targets on held-out seeds: goal task (jitter: success at least,
#: collisions at most), arena (jitter: avoidance rate at least), and the arena's least
#: distance against the Oracle's; `TARGETS_SOURCE` names the issue.
TARGETS_SOURCE = "issue 16's (the robot avoids obstacles)"
GOAL_TARGETS = {1.0: (0.60, 0.15), 2.0: (0.50, None)}
ARENA_TARGETS = {0.0: 0.95, 1.0: 0.90}
ARENA_DISTANCE = 0.70

#: Why the manoeuvre's constants are shared (a statement of the design, not a result).
CONSTANTS = (
    "**The controller's constants.** The manoeuvre's constants (avoid time, turn, pass "
    "time, refractory: `lgmd_sim.controllers.avoid.AvoidParams`) are the same for every "
    "detector, as tuned for the Oracle on RoughTerrainObstacles, and are not tuned per "
    "detector: each detector's calibration is tuned to the manoeuvre instead. Its window "
    "of times to collision is where the Oracle, this manoeuvre triggered by the ground "
    "truth, meets the target (above), so that a detector alarming in the window gets the "
    "Oracle's manoeuvre at the Oracle's moment. Tuned per detector, the constants would "
    "absorb a detector's timing errors (a late alarm by a sharper turn), and the "
    "benchmark would compare detector-and-controller pairs, not detectors.")


def _wall(run: Path) -> str:
    seconds = json.loads((run / "run.json").read_text()).get("wall_time_s")
    return f"{seconds / 60:.0f} min" if seconds else "unknown"


def _pct(row: dict[str, str], what: str) -> str:
    if not row.get(f"{what}_rate"):
        return "-"
    return (f"{100 * float(row[f'{what}_rate']):.0f}% [{100 * float(row[f'{what}_ci_low']):.0f}"
            f", {100 * float(row[f'{what}_ci_high']):.0f}]")


def _cell(row: dict[str, str]) -> str:
    name = f"{row['model']}/{row['preset']}" if row["model"] else row["controller"]
    return name + (f" ({row['side']})" if row.get("side") and row["side"] != "halves" else "")


def oracle_section(run: Path) -> list[str]:
    rows = sorted(_rows(run / "summary.csv"), key=lambda r: (float(r["jitter"]), horizon(r)))
    lines = ["### How early the manoeuvre must start", "",
             "The Oracle (the manoeuvre triggered by the ground truth) triggered at a range of "
             "times to collision, on seeds that are neither the calibration's nor the "
             "benchmark's:", "", "```bash", _command(run), "```", "",
             "| jitter | trigger TTC (s) | episodes | success % [95% CI] | collisions % "
             "[95% CI] | progress |", "|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {float(r['jitter']):g} | {horizon(r):g} | {r['episodes']} | "
                     f"{_pct(r, 'success')} | {_pct(r, 'collision')} | "
                     f"{float(r['mean_progress']):.2f} |")
    lines.append("")
    for j in sorted({float(r["jitter"]) for r in rows}):
        found = window([r for r in rows if float(r["jitter"]) == j])
        text = (f"from {found[0]:g} to {found[1]:g} s" if found else "at no horizon tried")
        agrees = found == (robot.TTC_LO, robot.TTC_HI)
        lines.append(f"- **jitter {j:g}:** the Oracle meets the target, {TARGETS_SOURCE} "
                     f"at jitter 1 (success "
                     f"{100 * SUCCESS:.0f}% or more, collisions {100 * COLLISIONS:.0f}% or "
                     f"fewer) when triggered {text}; the robot objective's window is "
                     f"[{robot.TTC_LO:g}, {robot.TTC_HI:g}] s"
                     + (" (this run's)." if agrees else " (not this run's: remake it)."))
    return [*lines, ""]


def calibration_section(run: Path, figures: Figures) -> list[str]:
    data = json.loads((run / "calibrated.json").read_text())
    lines = ["### Calibrated on the robot's own camera", "", "```bash", _command(run), "```",
             "", f"Wall time {_wall(run)}. The shipped `robot*` presets are this run's "
             f"(`docs/experiments/tools/ship_presets.py {run}`).", "", data["objective"], "",
             f"Each detector's best setting on the search seeds (the same budget of "
             f"{data['budget']} settings each), and the same setting on the held-out seeds "
             "(search / held-out):", "", (run / "summary.md").read_text().strip(), ""]
    lines += by_scenario(run, data)
    for fig in _copy(run, ["calibration.png"], "calibration-robot", figures):
        lines += [f"![{fig}]({fig})", ""]
    return lines


def by_scenario(run: Path, data: dict) -> list[str]:
    """Each chosen detector's held-out hits by the scenario of the clips: an approach clip
    is hit when its first alarm falls in the window, a clear clip when it stays silent."""
    config = json.loads((run / "run.json").read_text())["config"]
    first, n = config["heldout_seeds"]
    # in the order the calibration scored them: its run folder's, by key
    clips = sorted(specs({k: [(sc, tuple(j)) for sc, j in v]
                          for k, v in config["groups"].items()}, range(first, first + n)),
                   key=lambda c: c.key)
    scenarios = list(dict.fromkeys(c.scenario for c in clips))
    lines = ["Held-out clips hit, by scenario (approach: the first alarm in the window; "
             "clear: no alarm):", "",
             "| detector | " + " | ".join(scenarios) + " |", "|---|" + "---:|" * len(scenarios)]
    for path in sorted((run / "records").glob("*.json")):
        record = json.loads(path.read_text())
        if "sets" not in record:
            continue  # a clip's record
        model, name = preset_name(record["detector"], config.get("task", "walker"))
        chosen = data["presets"][model][name]
        params = {k: v for k, v in chosen["params"].items() if k not in ("threshold",
                                                                           "stabilize")}
        if json.dumps(record["params"], sort_keys=True) != json.dumps(params, sort_keys=True):
            continue
        at = int(abs(THRESHOLDS - chosen["params"]["threshold"]).argmin())
        hit = unpack_hits(record["sets"]["heldout"]["hits"], len(clips))[:, at]
        rates = [hit[[c.scenario == sc for c in clips]] for sc in scenarios]
        lines.append(f"| {record['detector']} | "
                     + " | ".join(f"{int(r.sum())}/{len(r)}" for r in rates) + " |")
    return [*lines, ""]


def _best_goal(rows: Sequence[dict[str, str]]) -> dict[str, str] | None:
    return max(rows, key=lambda r: (float(r["success_rate"]), -float(r["collision_rate"])),
               default=None)


def _best_arena(rows: Sequence[dict[str, str]]) -> dict[str, str] | None:
    far = [r for r in rows if r["distance_vs_oracle"] and r["avoidance_rate"]
           and float(r["distance_vs_oracle"]) >= ARENA_DISTANCE]
    return max(far, key=lambda r: float(r["avoidance_rate"]), default=None)


def targets(rows: Sequence[dict[str, str]]) -> list[str]:
    """Each target against the best LGMD-driven cell, in sentences computed from the rows."""
    out = ["### Against the targets (held-out seeds)", ""]
    reactive = [r for r in rows if r["controller"] == "reactive"]
    for (scenario, jitter), rs in sorted(_by(reactive).items()):
        oracle = next((r for r in rows if r["controller"] == "oracle" and not r["tag"]
                       and r["scenario"] == scenario and float(r["jitter"]) == jitter), None)
        if rs[0]["task"] == "goal":
            best = _best_goal(rs)
            success, collisions = GOAL_TARGETS.get(jitter, (None, None))
            met = (success is not None and float(best["success_rate"]) >= success
                   and (collisions is None or float(best["collision_rate"]) <= collisions))
            goal = ("" if success is None else
                    f" Target, {TARGETS_SOURCE}: success {100 * success:.0f}% or more"
                    + (f" with collisions {100 * collisions:.0f}% or fewer" if collisions
                       else "") + (": met." if met else ": not met."))
            out.append(f"- **{scenario}, jitter {jitter:g}:** the most successes with "
                       f"{_cell(best)}: success {_pct(best, 'success')}, collisions "
                       f"{_pct(best, 'collision')}, "
                       f"{float(best['false_alarms_per_min']):.1f} false alarms a minute."
                       + (f" Oracle: success {_pct(oracle, 'success')}, collisions "
                          f"{_pct(oracle, 'collision')}." if oracle else "") + goal
                       + why(best))
        else:
            best = _best_arena(rs)
            need = ARENA_TARGETS.get(jitter)
            if best is None:
                out.append(f"- **{scenario}, jitter {jitter:g}:** no LGMD-driven cell covers "
                           f"{100 * ARENA_DISTANCE:.0f}% of the Oracle's distance."
                           + (f" Target, {TARGETS_SOURCE}: {100 * need:.0f}% or more: not "
                              "met." if need else ""))
                continue
            met = need is not None and float(best["avoidance_rate"]) >= need
            out.append(f"- **{scenario}, jitter {jitter:g}:** of the LGMD-driven cells covering "
                       f"{100 * ARENA_DISTANCE:.0f}% or more of the Oracle's distance, the "
                       f"best avoider is {_cell(best)}: {_pct(best, 'avoidance')} of "
                       f"{best['encounters']} encounters avoided, "
                       f"{float(best['distance_vs_oracle']):.2f} of the Oracle's distance, "
                       f"{float(best['collisions_per_min']):.1f} collisions and "
                       f"{float(best['false_alarms_per_min']):.1f} false alarms a minute."
                       + (f" Oracle: {_pct(oracle, 'avoidance')} avoided." if oracle else "")
                       + ("" if need is None else f" Target, {TARGETS_SOURCE}: "
                          f"{100 * need:.0f}% or more"
                          + (": met." if met else ": not met.")) + why(best))
    return [*out, ""]


def _collided(best: dict[str, str]) -> list[dict[str, str]]:
    """The episodes of `best`'s cell that collided, from its run's episodes.csv."""
    return [e for e in _rows(Path(best["run"]) / "episodes.csv")
            if all(e[k] == best[k] for k in ("scenario", "jitter", "controller", "model",
                                             "preset", "side"))
            and e["collided"] == "True"]


def _leads(episodes: Sequence[dict[str, str]]) -> list[float | None]:
    return [float(e["lead_time_s"]) if e["lead_time_s"] else None for e in episodes]


def why(best: dict[str, str]) -> str:
    """What came before each of a cell's collisions: its last alarm's lead (none, later
    than the window, in it, earlier), from the run's episodes."""
    leads = _leads(_collided(best))
    counts = [sum(v is None for v in leads),
              sum(v is not None and v < robot.TTC_LO for v in leads),
              sum(v is not None and robot.TTC_LO <= v <= robot.TTC_HI for v in leads),
              sum(v is not None and v > robot.TTC_HI for v in leads)]
    return (f" Of its {len(leads)} episodes with a collision, the last alarm onset before "
            f"the (first) collision came: none in {counts[0]}, less than {robot.TTC_LO:g} s "
            f"before it in {counts[1]}, {robot.TTC_LO:g} to {robot.TTC_HI:g} s before it "
            f"(the window's times to collision) in {counts[2]}, more than "
            f"{robot.TTC_HI:g} s before it in {counts[3]}.")


#: Bins of the collisions figure: the last alarm's lead before the collision (s).
LEAD_BINS = np.arange(0.0, 3.01, 0.15)


def collisions_figure(bests: Sequence[dict[str, str]], path: Path) -> None:
    """Per jitter level of the goal task, the best LGMD-driven cell's collided episodes by
    the lead of their last alarm onset before the collision (none: the leftmost bar),
    the robot objective's window shaded: what a detector did before each collision."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(bests), figsize=(4.2 * len(bests), 3.4), sharey=True,
                             squeeze=False)
    for ax, best in zip(axes[0], bests, strict=True):
        leads = _leads(_collided(best))
        timed = np.clip([v for v in leads if v is not None], 0, LEAD_BINS[-1])
        ax.axvspan(robot.TTC_LO, robot.TTC_HI, color="tab:green", alpha=0.15,
                   label="the window")
        ax.bar(-0.3, sum(v is None for v in leads), width=0.25, color="tab:grey",
               label="no alarm")
        ax.hist(timed, bins=LEAD_BINS, color="tab:red", label="last alarm's lead")
        ax.set_xticks([-0.3, 0, 1, 2, 3], ["none", "0", "1", "2", "3+"])
        ax.set_xlabel("last alarm onset before the collision (s)")
        ax.set_title(f"{best['scenario']}, jitter {float(best['jitter']):g}\n"
                     f"{_cell(best)}: {len(leads)} collisions", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("episodes")
    axes[0][-1].legend(fontsize=8, loc="upper center")
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _by(rows: Sequence[dict[str, str]]) -> dict[tuple[str, float], list[dict[str, str]]]:
    groups: dict[tuple[str, float], list[dict[str, str]]] = {}
    for r in rows:
        groups.setdefault((r["scenario"], float(r["jitter"])), []).append(r)
    return groups


def attribution(rows: Sequence[dict[str, str]]) -> list[str]:
    """Which part does the work: per task and jitter level, every model under every preset
    and side (the calibration, the front end, the eyes), the feedback LGMD's open-loop
    control among its presets."""
    out = ["### Which part does the work", "",
           "Per task and jitter level: each model (rows) under each preset and way of "
           "choosing the side (columns), the same held-out seeds; the goal task gives "
           "success [95% CI] / collisions (%), the arena encounters avoided [95% CI] / "
           "distance against the Oracle's. `robot` against the model's default preset is "
           "the calibration, "
           "`robot-imu` and `robot-image` against `robot` the front end, `eyes` against "
           "`halves` the two eyes, the feedback LGMD's `robot-open-loop*` against "
           "`robot*` its loop.", ""]
    reactive = [r for r in rows if r["controller"] == "reactive"]
    for (scenario, jitter), rs in sorted(_by(reactive).items()):
        columns = sorted({(r["preset"].replace("-open-loop", ""), r["side"] or "halves")
                          for r in rs}, key=lambda c: (c[0], c[1] != "halves", c[1]))
        models = sorted({r["model"] for r in rs} | {f"{r['model']} (open loop)" for r in rs
                                                    if "open-loop" in r["preset"]})
        head = [f"{p}, {s}" for p, s in columns]
        out += [f"**{scenario}, jitter {jitter:g}**", "",
                "| model | " + " | ".join(head) + " |",
                "|---|" + "---:|" * len(head)]
        for model in models:
            base, loop_open = model.removesuffix(" (open loop)"), model.endswith("(open loop)")
            cells = []
            for preset, side in columns:
                # the open-loop control exists only for the calibrated presets
                want = (preset.replace("robot", "robot-open-loop", 1) if loop_open
                        and preset.startswith("robot") else None if loop_open else preset)
                r = next((r for r in rs if r["model"] == base and r["preset"] == want
                          and (r["side"] or "halves") == side), None)
                cells.append("" if r is None else _measure(r))
            out.append(f"| {model} | " + " | ".join(cells) + " |")
        out.append("")
    return out


def _measure(r: dict[str, str]) -> str:
    if r["task"] == "goal":
        return f"{_pct(r, 'success')} / {100 * float(r['collision_rate']):.0f}"
    distance = float(r["distance_vs_oracle"]) if r["distance_vs_oracle"] else float("nan")
    return f"{_pct(r, 'avoidance')} / {distance:.2f}"


def _cell_id(row: dict[str, str]) -> tuple[str, ...]:
    return tuple(row[k] or "" for k in ("scenario", "jitter", "controller", "model", "preset",
                                         "tag", "side"))


def _shared(run: Path, others: Sequence[Path]) -> int:
    """How many of `run`'s episode records are byte for byte one of `others`' (episodes a
    run took from earlier ones with the same code, seeds and options)."""
    theirs = {p.name: p for other in others for p in (other / "records").glob("*.json")}
    return sum(p.name in theirs and p.read_bytes() == theirs[p.name].read_bytes()
               for p in (run / "records").glob("*.json"))


#: An encounter map of a roam scenario at one jitter level, as the benchmark names it
#: (`lgmd_sim.benchmark.figures.encounters_figure`): its scenario and jitter.
ENCOUNTER_MAP = re.compile(r"encounters_(.+)_j([^_]+)\.png")
TAG = "closed-loop-robot"


def run_figures(run: Path, figures: Figures) -> list[str]:
    """Add a closed-loop run's figures to those to write under docs/results/closed-loop-robot/;
    their paths relative to the page, by name. Each is copied as it is but a scenario's
    encounter maps (one a jitter level), which the page shows together: they are one figure
    of the repository, encounters_<scenario>.png, a jitter level a panel from the lowest."""
    plain, maps = [], {}
    for path in sorted(run.glob("*.png")):
        match = ENCOUNTER_MAP.fullmatch(path.name)
        try:
            jitter = float(match[2]) if match else None
        except ValueError:
            jitter = None
        if jitter is None:
            plain.append(path.name)
        else:
            maps.setdefault(match[1], []).append((jitter, path))
    links = _copy(run, plain, TAG, figures)
    for scenario, parts in maps.items():
        target = FIGURES / TAG / f"encounters_{scenario}.png"
        figures[target] = stacked([path for _, path in sorted(parts)])
        links.append(f"{FIGURES_LINK}/{TAG}/{target.name}")
    return sorted(links)


def closed_loop_section(runs: Sequence[Path], figures: Figures) -> list[str]:
    """The closed-loop runs (the same episode seeds: their cells are compared as one
    table): the first with its command, wall time, summary and figures, each further one
    with its command and the cells it adds; then the targets and which part does the work
    over all of their cells."""
    seeds = {json.dumps(json.loads((r / "run.json").read_text())["config"]["seeds"])
             for r in runs}
    if len(seeds) > 1:
        raise SystemExit(f"robot_page.py: the closed-loop runs ran different seeds ({seeds})")
    main, *more = runs
    lines = ["### Closed loop: the goal and the arena", "",
             "Two tasks: RoughTerrainObstacles (reach the goal 8 m ahead through obstacles) "
             "and ArenaRoam (roam a walled arena with obstacles for 30 s; collisions do not "
             "end it), both over rough ground. " + encounters.__doc__.strip(), "",
             "```bash", _command(main), "```", ""]
    shared = _shared(main, more)
    episodes = len(list((main / "records").glob("*.json")))
    lines += [f"Wall time {_wall(main)} for {episodes} episodes"
              + (f", {shared} of which (identical records) it took from the runs below, whose "
                 "wall time is theirs." if shared else ".") + " "
              + "The figures, from its folder: collisions and successes against jitter, false "
              "alarms against collisions, the trajectories of the first seed, the arena's "
              "rates against jitter and where its encounters happened (avoided or not), a "
              "jitter level a panel from the lowest down.", "",
              (main / "summary.md").read_text().strip(), ""]
    for fig in run_figures(main, figures):
        lines += [f"![{fig}]({fig})", ""]
    rows = [{**r, "run": str(main)} for r in _rows(main / "summary.csv")]
    for run in more:
        seen = {_cell_id(r) for r in rows}
        added = [{**r, "run": str(run)} for r in _rows(run / "summary.csv")
                 if r["controller"] == "reactive" and _cell_id(r) not in seen]
        lines += ["```bash", _command(run), "```", "",
                  f"Wall time {_wall(run)}. Its cells not in the runs above, in the tables "
                  "below: " + ", ".join(sorted({_cell(r) for r in added})) + ".", ""]
        rows += added
    lines += targets(rows)
    bests = [_best_goal(rs) for (_, _), rs in sorted(_by(
        [r for r in rows if r["controller"] == "reactive" and r["task"] == "goal"]).items())]
    if bests:
        target = FIGURES / "closed-loop-robot" / "collisions_lead.png"
        figures[target] = lambda tmp: collisions_figure(bests, tmp)
        name = f"{FIGURES_LINK}/closed-loop-robot/{target.name}"
        lines += ["What came before each collision of the goal task's best LGMD-driven cell "
                  "per jitter level (the most successes): the lead of the last alarm onset "
                  "before the collision, the window shaded.", "", f"![{name}]({name})", ""]
    lines += attribution(rows)
    return [*lines, CONSTANTS, ""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--oracle-window", type=Path, required=True)
    parser.add_argument("--calibration", type=Path, required=True)
    parser.add_argument("--closed-loop", type=Path, nargs="+", default=[],
                        help="closed-loop runs on the same seeds: the first one shown "
                        "whole, each further one adding its cells")
    args = parser.parse_args()
    figures: Figures = {}
    lines = [BEGIN, "", "## The robot: its own calibration, two eyes, two tasks", ""]
    lines += oracle_section(args.oracle_window)
    lines += calibration_section(args.calibration, figures)
    if args.closed_loop:
        lines += closed_loop_section(args.closed_loop, figures)
    lines.append(END)
    page = OUT.read_text()
    start, end = page.find(BEGIN), page.find(END)
    section = "\n".join(lines) + "\n"
    text = (page[:start] + section + page[end + len(END) + 1:] if start >= 0 and end > start
            else page.rstrip() + "\n\n" + section)
    write_files({OUT: lambda tmp: tmp.write_text(text),
                 **{target: _copier(source) for target, source in figures.items()}})
    print(f"wrote {OUT.relative_to(ROOT)} and {FIGURES.relative_to(ROOT)}/")


if __name__ == "__main__":
    main()
