"""`lgmd-sim bench closed-loop`: which detector lets a robot avoid obstacles, at what cost.

Every cell (scenario, jitter level, controller, detector) runs the same list of episode
seeds, so cells differ only in what drives the carrier. Controllers: `Straight` (no
avoidance: the floor), `Oracle` (the manoeuvre triggered by ground truth: the ceiling,
and the check that the manoeuvre can avoid at all) and `ReactiveAvoid` with each detector
(an LGMD model and preset) and each way of choosing the side to turn away to
(`ClosedLoopConfig.sides`). Per episode one record (``DIR/records/<key>.json``, gathered
into ``DIR/episodes.csv``); per cell the rates with 95% Wilson intervals
(``DIR/summary.csv``, ``DIR/summary.md``); and figures (``DIR/*.png``).

Alarms are the controller's detector firing (an LGMD alarm, or the Oracle's trigger),
counted at their onsets; an alarm is false when no obstacle is within ``horizon`` seconds
of collision at that frame (``info["threat_ttc"]``). The lead time of a collision is the
time from the last alarm onset before it; the first alarm's time to collision is the
ground truth's at the first onset.

Two kinds of task: a scenario with a goal (its infos carry ``goal_distance``), whose cells
report collision and success rates and progress; and a roam task without one (ArenaRoam:
a fixed time in a walled arena, collisions not ending the episode), whose cells report
collisions per minute, the share of encounters avoided (`lgmd_sim.bench.encounters`
defines them), the distance travelled against the Oracle's and the share of the time
spent manoeuvring. Every record carries both kinds of figure where they apply.
"""

from __future__ import annotations

import math
import statistics
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import metrics, options
from lgmd_sim.bench import encounters
from lgmd_sim.controllers.avoid import ReactiveParams
from lgmd_sim.fileio import atomic_folder_outputs, csv_text, write_text_atomic
from lgmd_sim.parallel import Job, run_jobs
from lgmd_sim.runs import NULL, NUMBER, Maybe, RunFolder, RunResult

__all__ = ["DEFAULT_SIDE", "Cell", "ClosedLoopConfig", "episode", "plan", "run", "summarise",
           "summary_markdown"]

#: ReactiveParams.side's default (one LGMD over the whole view, the side from its S
#: layer's halves: the behaviour from before there was a choice). Cells at it carry no
#: side parameter, so that their labels, keys and run folders stay what they were.
DEFAULT_SIDE: str = ReactiveParams().side


@dataclass(frozen=True)
class Cell:
    """What one row of the summary compares: a controller (and its detector) in a scenario
    at a jitter level.

    Attributes:
        model, preset: the LGMD model of a controller driven by one (`uses_model`).
        params: further controller parameters, as (name, value) pairs (("side", "eyes")
            for a reactive controller with two eyes).
        tag: a short name for the cell's controller where the parameters would make a long
            one (e.g. a trained policy's name); it appears in labels and file names.
    """

    scenario: str
    jitter: float
    controller: str
    model: str | None = None
    preset: str | None = None
    params: tuple[tuple[str, Any], ...] = ()
    tag: str | None = None

    @property
    def side(self) -> str | None:
        """The side parameter of the cell where it is not `DEFAULT_SIDE`, else None."""
        side = dict(self.params).get("side")
        return None if side == DEFAULT_SIDE else side

    @property
    def label(self) -> str:
        """"reactive: feedback/paper", "reactive: feedback/paper, eyes", "oracle",
        "straight", "policy: ppo-feedback"."""
        detail = f"{self.model}/{self.preset}" if self.model else self.tag
        side = f", {self.side}" if self.side else ""
        return self.controller + (f": {detail}" if detail else "") + side

    def key(self, seed: int) -> str:
        detail = f"-{self.model}-{self.preset}" if self.model else (
            f"-{self.tag}" if self.tag else "")
        side = f"-{self.side}" if self.side else ""
        return f"{self.scenario}-j{self.jitter:g}-{self.controller}{detail}{side}-s{seed}"


def episode(cell: Cell, seed: int, *, resolution: Any, cruise: float, horizon: float,
            top_view: bool = False) -> dict[str, Any]:
    """Run one episode of `cell` and measure it (a job: runs in a worker process)."""
    import gymnasium as gym

    from lgmd_sim import controllers
    from lgmd_sim.envs.catalogue import scenario

    params = dict(cell.params)
    if cell.model:
        params.update(model=cell.model, preset=cell.preset)
    if "cruise" in controllers.controller_class(cell.controller).Params.names():
        params.setdefault("cruise", cruise)  # every cruising controller at the same speed
    controller = controllers.make(cell.controller, **params)
    env = controller.wrap_env(gym.make(scenario(cell.scenario).env_id, jitter=cell.jitter,
                                       resolution=resolution))
    infos, alarms, manoeuvring = [], [], []
    try:
        for step in controllers.rollout(env, controller, seed=seed):
            infos.append(step.info)
            alarms.append(step.action is not None and controller.alarm)
            if step.action is not None:
                manoeuvring.append(controller.manoeuvring)
        view = env.unwrapped.world.top_view() if top_view else None
    finally:
        env.close()
    first, last = infos[0], infos[-1]
    xy = np.array([i["carrier_pos"][:2] for i in infos])
    times = np.array([i["time"] for i in infos])
    travelled = float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())
    alarm = np.array(alarms)
    onsets = np.flatnonzero(alarm & ~np.r_[False, alarm[:-1]])
    ttc_at = np.array([infos[t]["threat_ttc"] for t in onsets])
    false_alarms = int((ttc_at > horizon).sum())
    collision = int(last["first_collision_frame"])
    found = encounters.encounters(infos)
    collisions = len(encounters.collision_onsets(infos))
    minutes = times[-1] / 60
    record: dict[str, Any] = {
        "scenario": cell.scenario, "jitter": cell.jitter, "controller": cell.controller,
        "model": cell.model, "preset": cell.preset, "tag": cell.tag, "side": cell.side,
        "seed": seed, "task": "goal" if "goal_distance" in first else "roam",
        "frames": len(infos), "time_s": _finite(times[-1]),
        "collided": collision >= 0, "goal_reached": bool(last.get("goal_reached", False)),
        "distance_m": _finite(travelled),
        "alarms": len(onsets), "false_alarms": false_alarms,
        "false_alarms_per_min": _finite(false_alarms / minutes) if minutes else None,
        "first_alarm_ttc_s": _finite(ttc_at[0]) if len(onsets) else None,
        "lead_time_s": _lead_time(times, onsets, collision),
        "min_clearance_m": _finite(min(i["threat_distance"] for i in infos)),
        "collisions": collisions,
        "collisions_per_min": _finite(collisions / minutes) if minutes else None,
        "encounters": len(found), "avoided": sum(e.avoided for e in found),
        # None where the controller cannot tell (a trained policy)
        "manoeuvring_share": (_finite(np.mean(manoeuvring))
                              if manoeuvring and None not in manoeuvring else None),
    }
    if "goal_distance" in first:  # a scenario with a goal
        start = first["goal_distance"]
        record.update(straight_line_m=_finite(start), path_ratio=_finite(travelled / start),
                      progress=_finite((start - last["goal_distance"]) / start))
    if view is not None:
        view["path"] = np.round(xy, 3).tolist()
        view["collision_frame"] = collision if collision >= 0 else None
        view["encounters"] = [[round(e.x, 3), round(e.y, 3), e.avoided] for e in found]
        record["top_view"] = view
    return record


#: What the tables read of an episode's record: one holding less is refused on resuming.
#: The fields from before the arena task (side, task, collisions, encounters, ...) may be
#: missing, so that older run folders still resume: their records are goal tasks.
RECORD_FIELDS = {
    "scenario": str, "jitter": NUMBER, "controller": str, "model": (str, NULL),
    "preset": (str, NULL), "tag": Maybe((str, NULL)), "side": Maybe((str, NULL)),
    "seed": int, "task": Maybe(str), "time_s": NUMBER, "distance_m": (NUMBER, NULL),
    "collided": bool, "goal_reached": bool, "false_alarms": int,
    "progress": Maybe((NUMBER, NULL)),
    "first_alarm_ttc_s": (NUMBER, NULL), "lead_time_s": (NUMBER, NULL),
    "collisions": Maybe(int), "encounters": Maybe(int), "avoided": Maybe(int),
    "manoeuvring_share": Maybe((NUMBER, NULL)),
}


def _lead_time(times: np.ndarray, onsets: np.ndarray, collision: int) -> float | None:
    """Seconds from the last alarm onset at or before the collision to the collision."""
    before = onsets[onsets <= collision] if collision >= 0 else onsets[:0]
    return _finite(times[collision] - times[before[-1]]) if len(before) else None


def _finite(x: float) -> float | None:
    """JSON-safe: None for an infinite or undefined value, else rounded."""
    x = float(x)
    return round(x, 4) if math.isfinite(x) else None
# --- the sweep ----------------------------------------------------------------------------


def plan(scenarios: Sequence[str], jitters: Sequence[float], controllers: Sequence[str],
         detectors: Sequence[tuple[str, str]], sides: Sequence[str] = (DEFAULT_SIDE,)
         ) -> list[Cell]:
    """Every cell of a sweep: controllers driven by a model get one cell per detector, and
    those whose parameters have a ``side`` one per detector and side."""
    from lgmd_sim.controllers import controller_class

    cells = []
    for sc in scenarios:
        for j in jitters:
            for name in controllers:
                cls = controller_class(name)
                variants = ([(("side", s),) if s != DEFAULT_SIDE else () for s in sides]
                            if "side" in cls.Params.names() else [()])
                detected = detectors if cls.uses_model else [(None, None)]
                cells += [Cell(sc, j, name, m, p, params) for m, p in detected
                          for params in variants]
    return cells


def _cell_of(record: dict[str, Any]) -> Cell:
    """The cell of an episode's record, as far as its label goes (not a policy's path)."""
    side = record.get("side")
    return Cell(record["scenario"], record["jitter"], record["controller"], record["model"],
                record["preset"], (("side", side),) if side else (), record.get("tag"))


def _median(values: Sequence[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return statistics.median(kept) if kept else None


def _mean(values: Sequence[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else None


def summarise(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per cell: rates with 95% Wilson intervals, false alarms per minute, median
    first-alarm time to collision and lead time, mean distance travelled; for goal tasks
    the success rate and mean progress; where the records count them (all but those from
    before the arena task) collisions per minute, the share of the pooled encounters
    avoided, the mean distance relative to the Oracle's (the untagged oracle cell of the
    same scenario and jitter level, over the seeds both have a distance for; None without
    one) and the mean share of the time spent manoeuvring (None where the controller
    cannot tell)."""
    groups: dict[tuple, list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        groups[(r["scenario"], r["jitter"], r["controller"], r["model"], r["preset"],
                r.get("tag"), r.get("side"))].append(r)
    rows = []
    for (sc, j, ctrl, model, preset, tag, side), rs in groups.items():
        n = len(rs)
        goal = rs[0].get("task", "goal") == "goal"  # records from before roam tasks: goal
        collided = sum(r["collided"] for r in rs)
        reached = sum(r["goal_reached"] for r in rs)
        minutes = sum(r["time_s"] for r in rs) / 60
        progress = [r["progress"] for r in rs if r.get("progress") is not None]
        counted = all("encounters" in r for r in rs)
        met = sum(r["encounters"] for r in rs) if counted else 0
        avoided = sum(r["avoided"] for r in rs) if counted else 0
        rows.append({
            "scenario": sc, "jitter": j, "controller": ctrl, "model": model, "preset": preset,
            "tag": tag, "side": side, "task": "goal" if goal else "roam",
            "cell": _cell_of(rs[0]).label, "episodes": n,
            "collision_rate": collided / n, "collision_ci": metrics.wilson_interval(collided, n),
            "success_rate": reached / n if goal else None,
            "success_ci": metrics.wilson_interval(reached, n) if goal else None,
            "false_alarms_per_min": sum(r["false_alarms"] for r in rs) / minutes,
            "median_first_alarm_ttc_s": _median([r["first_alarm_ttc_s"] for r in rs]),
            "median_lead_time_s": _median([r["lead_time_s"] for r in rs]),
            "mean_progress": float(np.mean(progress)) if progress else None,
            "mean_time_s": float(np.mean([r["time_s"] for r in rs])),
            "mean_distance_m": _mean([r["distance_m"] for r in rs]),
            "collisions": sum(r["collisions"] for r in rs) if counted else None,
            "collisions_per_min": (sum(r["collisions"] for r in rs) / minutes
                                   if counted else None),
            "encounters": met if counted else None,
            "avoided": avoided if counted else None,
            "avoidance_rate": avoided / met if met else None,
            "avoidance_ci": metrics.wilson_interval(avoided, met) if met else None,
            "manoeuvring_share": _mean([r.get("manoeuvring_share") for r in rs]),
        })
    # the Oracle: the planned cell, untagged (an extra cell with parameters has a tag)
    distances = {key: {r["seed"]: r["distance_m"] for r in rs} for key, rs in groups.items()}
    for key, row in zip(groups, rows, strict=True):
        base = distances.get((*key[:2], "oracle", None, None, None, None), {})
        row["distance_vs_oracle"] = _paired_ratio(distances[key], base)
    return rows


def _paired_ratio(values: dict[int, float | None], base: dict[int, float | None]
                  ) -> float | None:
    """The mean of `values` over the mean of `base` (each by seed), over the seeds both
    have a value for; None without one, or where the base's is 0."""
    seeds = [s for s, v in values.items() if v is not None and base.get(s) is not None]
    below = sum(base[s] for s in seeds)
    return sum(values[s] for s in seeds) / below if below else None


_EPISODE_COLUMNS = ["scenario", "jitter", "controller", "model", "preset", "tag", "side",
                    "seed", "task", "frames",
                    "time_s", "collided", "goal_reached", "distance_m", "straight_line_m",
                    "path_ratio", "progress", "alarms", "false_alarms", "false_alarms_per_min",
                    "first_alarm_ttc_s", "lead_time_s", "min_clearance_m", "collisions",
                    "collisions_per_min", "encounters", "avoided", "manoeuvring_share"]
#: summary.csv's columns: every row has them all, empty where they do not apply.
_SUMMARY_COLUMNS = ["scenario", "jitter", "controller", "model", "preset", "tag", "side",
                    "task", "episodes", "collision_rate", "collision_ci_low",
                    "collision_ci_high", "success_rate", "success_ci_low", "success_ci_high",
                    "false_alarms_per_min", "median_first_alarm_ttc_s", "median_lead_time_s",
                    "mean_progress", "mean_time_s", "mean_distance_m", "distance_vs_oracle",
                    "collisions", "collisions_per_min", "encounters", "avoided",
                    "avoidance_rate", "avoidance_ci_low", "avoidance_ci_high",
                    "manoeuvring_share"]


def _fmt(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def _percent(rate: float | None, ci: tuple[float, float] | None) -> str:
    """A rate in percent with its 95% interval, "-" where there is none."""
    if rate is None or ci is None:
        return "-"
    return f"{100 * rate:.0f} [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]"


def _percent_of(share: float | None) -> str:
    return "-" if share is None else f"{100 * share:.0f}"


_GOAL_LEGEND = ("_collisions, success: shares of the episodes with a collision and reaching "
                "the goal (95% Wilson intervals); false alarm: an alarm onset with no "
                "obstacle within the horizon's time to collision; lead time: from the last "
                "alarm onset to the collision; progress: share of the way to the goal "
                "covered._")
_ROAM_LEGEND = (f"_{encounters.LEGEND}; avoided %: of the cell's pooled encounters (95% "
                "Wilson interval, too narrow: encounters cluster by episode); collisions / "
                "min: collision onsets; false alarm: an alarm onset with no obstacle "
                "within the horizon's time to collision; distance vs Oracle: mean distance "
                "travelled over the Oracle's on the seeds both have; manoeuvring: share of "
                "the time braking and turning away (-: the controller cannot tell)._")


def summary_markdown(rows: Sequence[dict[str, Any]]) -> str:
    """The summary as Markdown: a table of the goal tasks' cells and one of the roam
    tasks' (rates in percent with their 95% intervals), each with its legend."""
    goal = [r for r in sorted(rows, key=_order) if r.get("task", "goal") == "goal"]
    roam = [r for r in sorted(rows, key=_order) if r.get("task") == "roam"]
    blocks = []
    if goal:
        lines = ["| scenario | jitter | controller | episodes | collisions % [95% CI] | "
                 "success % [95% CI] | false alarms / min | first alarm TTC (s, median) | "
                 "lead time (s, median) | progress |",
                 "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['scenario']} | {r['jitter']:g} | {r['cell']} | {r['episodes']} | "
                  f"{_percent(r['collision_rate'], r['collision_ci'])} | "
                  f"{_percent(r['success_rate'], r['success_ci'])} | "
                  f"{_fmt(r['false_alarms_per_min'])} | "
                  f"{_fmt(r['median_first_alarm_ttc_s'])} | "
                  f"{_fmt(r['median_lead_time_s'])} | {_fmt(r['mean_progress'])} |"
                  for r in goal]
        blocks += ["\n".join(lines), _GOAL_LEGEND]
    if roam:
        lines = ["| scenario | jitter | controller | episodes | encounters | "
                 "avoided % [95% CI] | collisions / min | false alarms / min | "
                 "distance (m, mean) | distance vs Oracle | manoeuvring % |",
                 "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['scenario']} | {r['jitter']:g} | {r['cell']} | {r['episodes']} | "
                  f"{'-' if r['encounters'] is None else r['encounters']} | "
                  f"{_percent(r['avoidance_rate'], r['avoidance_ci'])} | "
                  f"{_fmt(r['collisions_per_min'])} | {_fmt(r['false_alarms_per_min'])} | "
                  f"{_fmt(r['mean_distance_m'])} | {_fmt(r['distance_vs_oracle'])} | "
                  f"{_percent_of(r['manoeuvring_share'])} |" for r in roam]
        blocks += ["\n".join(lines), _ROAM_LEGEND]
    return "\n\n".join(blocks) + "\n"


def _order(r: dict[str, Any]) -> tuple:
    rank = {"oracle": 0, "reactive": 1, "straight": 2}.get(r["controller"], 1)
    return (r["scenario"], r["jitter"], rank, r["cell"])


def write_tables(folder: Path, records: Sequence[dict[str, Any]],
                 rows: Sequence[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """episodes.csv, summary.csv and summary.md from the records (and their summary,
    when it is made already); return the summary."""
    rows = summarise(records) if rows is None else list(rows)

    def bounds(r: dict[str, Any], what: str) -> dict[str, float | None]:
        low, high = r[f"{what}_ci"] or (None, None)
        return {f"{what}_ci_low": low, f"{what}_ci_high": high}

    flat = [{**r, **bounds(r, "collision"), **bounds(r, "success"), **bounds(r, "avoidance")}
            for r in sorted(rows, key=_order)]
    write_text_atomic(folder / "episodes.csv", csv_text(records, _EPISODE_COLUMNS))
    write_text_atomic(folder / "summary.csv", csv_text(flat, _SUMMARY_COLUMNS))
    write_text_atomic(folder / "summary.md", summary_markdown(rows))
    return rows


@dataclass(frozen=True)
class ClosedLoopConfig:
    """What a closed-loop benchmark runs, checked when it is made (a bad value raises a
    one-line ValueError naming it).

    Attributes:
        scenarios: catalogue scenario names (`lgmd-sim envs`).
        jitter: jitter levels; every cell runs at each.
        controllers: names of `lgmd_sim.controllers.available()`; one driven by a model
            gets a cell per detector.
        detectors: (model, preset) pairs, presets with any front ends
            ("published+image"); None: every model at its default preset.
        seeds: episodes per cell, seeded ``first_seed``, ``first_seed + 1``, ...
        first_seed: the first episode seed (1000 and up are never a training or
            validation seed of `lgmd-sim train`).
        resolution: the frame size, a preset name or (height, width).
        cruise: forward action of every cruising controller.
        horizon: an alarm is false when no obstacle is within this time to collision (s).
        extra: further cells run beside the planned ones on the same seeds (e.g. a
            trained policy's, from `lgmd-sim eval`).
        sides: how a controller with a ``side`` parameter (reactive) chooses the side to
            turn away to, each a cell of its own: "halves" (one LGMD over the whole view,
            the side from its S layer's halves) or "eyes" (two LGMDs over overlapping
            left and right parts of the view, away from the more excited).
    """

    scenarios: tuple[str, ...] = ("RoughTerrainObstacles",)
    jitter: tuple[float, ...] = (0.0, 1.0, 2.0)
    controllers: tuple[str, ...] = ("straight", "oracle", "reactive")
    detectors: tuple[tuple[str, str], ...] | None = None
    seeds: int = 50
    first_seed: int = 1000
    resolution: str | tuple[int, int] = "rl"
    cruise: float = 0.6
    horizon: float = 2.0
    extra: tuple[Cell, ...] = ()
    sides: tuple[str, ...] = (DEFAULT_SIDE,)

    def __post_init__(self) -> None:
        from lgmd_sim import controllers
        from lgmd_sim.envs.catalogue import scenarios

        def set_(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        set_("scenarios", tuple(options.names(self.scenarios, list(scenarios()),
                                              "scenario(s)")))
        set_("controllers", tuple(options.names(self.controllers, controllers.available(),
                                                "controller(s)")
                                  if self.controllers else ()))
        set_("jitter", tuple(float(j) for j in self.jitter))
        options.check_jitter(self.jitter)
        set_("detectors", options.detectors("all") if self.detectors is None
             else options.check_detectors(self.detectors))
        options.check_positive(self.seeds, "--seeds", integer=True)
        options.check_seed(self.first_seed, "--first-seed")
        set_("resolution", options.resolution(self.resolution))
        options.check_range(self.cruise, "--cruise", -1, 1)
        options.check_positive(self.horizon, "--horizon")
        set_("extra", tuple(self.extra))
        set_("sides", tuple(dict.fromkeys(self.sides)))
        if not self.sides:
            raise ValueError("--sides: no side given")
        for side in self.sides:
            if side != DEFAULT_SIDE:  # the default is the behaviour without the parameter
                _check_side(side)
        if not (self.controllers or self.extra):
            raise ValueError("no controllers given")
        keys = {cell.key(self.first_seed) for cell in plan(
            self.scenarios, self.jitter, self.controllers, self.detectors, self.sides)}
        for cell in self.extra:
            # records, keys and labels name no parameter but the side: a tag tells apart
            named = sorted(set(dict(cell.params)) - {"side"})
            where = f"extra cell {cell.label} ({cell.scenario}, jitter {cell.jitter:g})"
            if named and cell.tag is None:
                raise ValueError(f"{where}: parameters {', '.join(named)} need a tag")
            if cell.key(self.first_seed) in keys:
                raise ValueError(f"{where} is a cell of the run already: give it a tag")
            keys.add(cell.key(self.first_seed))

    @property
    def seed_list(self) -> list[int]:
        return list(range(self.first_seed, self.first_seed + self.seeds))

    def cells(self) -> list[Cell]:
        """Every cell: the planned ones, then the extra ones."""
        return plan(self.scenarios, self.jitter, self.controllers, self.detectors,
                    self.sides) + list(self.extra)

    def as_json(self) -> dict[str, Any]:
        """The configuration as the run folder records it (what identifies the run)."""
        from lgmd_sim.controllers import controller_class

        out: dict[str, Any] = {
            "benchmark": "closed-loop", "scenarios": list(self.scenarios),
            "jitter": list(self.jitter), "controllers": list(self.controllers),
            "detectors": [list(d) for d in self.detectors],
            "seeds": [self.first_seed, self.seeds],
            "resolution": self.resolution, "cruise": self.cruise, "horizon": self.horizon,
        }
        # only where a cell takes a side, so that a run from before sides still resumes;
        # the default first, then by name: the cells' order is not the run's identity
        if self.sides != (DEFAULT_SIDE,) and any(
                "side" in controller_class(c).Params.names() for c in self.controllers):
            out["sides"] = sorted(self.sides, key=lambda side: (side != DEFAULT_SIDE, side))
        if self.extra:
            out["extra"] = [{"scenario": c.scenario, "jitter": c.jitter,
                             "controller": c.controller, "params": dict(c.params),
                             "tag": c.tag} for c in self.extra]
        return out


def _check_side(side: str) -> None:
    """ValueError naming --sides where `side` is not a value of ReactiveParams.side."""
    from lgmd_sim.controllers.avoid import ReactiveParams

    try:
        ReactiveParams().replace(side=side)
    except ValueError as exc:
        raise ValueError(f"--sides {side!r}: {exc}") from None


def run(config: ClosedLoopConfig, out: str | Path, *, resume: bool = False,
        workers: int | None = None, ray_address: str | None = None,
        progress: bool | None = None, command: str = "") -> RunResult:
    """Run (or resume) the benchmark of `config` in folder `out`; write its tables and
    figures; return the summary rows (one per cell, as in summary.csv) and the files.

    Args:
        config: what runs.
        out: the run folder: new, empty, or (with `resume`) holding this configuration's
            run, whose finished episodes are kept.
        workers: local worker processes (default: every core; 1: in this process).
        ray_address: run the episodes as Ray tasks ("local", "auto" or "HOST:PORT").
        progress: show a progress bar (None: only on a terminal).
        command: the command line, for the run's record.
    """
    from lgmd_sim.bench import figures

    cells = config.cells()
    seeds = config.seed_list
    folder = RunFolder(out, config.as_json(), command, resume=resume)
    done = folder.done()
    episode_options = {"resolution": config.resolution, "cruise": config.cruise,
                       "horizon": config.horizon}
    jobs = [Job(cell.key(seed), episode, {"cell": cell, "seed": seed, **episode_options,
                                         "top_view": seed == seeds[0]})
            for cell in cells for seed in seeds if cell.key(seed) not in done]
    run_jobs(jobs, lambda job, record: folder.store(job.key, record), workers=workers,
             ray_address=ray_address, progress=progress, desc="closed-loop")
    records = folder.records([cell.key(seed) for cell in cells for seed in seeds],
                             RECORD_FIELDS)
    examples = [{**r, "cell": _cell_of(r).label} for r in records if "top_view" in r]
    records = [{k: v for k, v in r.items() if k != "top_view"} for r in records]
    rows = summarise(records)
    outputs = ["episodes.csv", "summary.csv", "summary.md",
               *figures.closed_loop_figures(rows, examples)]
    with atomic_folder_outputs(folder.path, outputs) as staging:  # all of them, or none
        write_tables(staging, records, rows)
        figures.closed_loop(staging, rows, examples)
    folder.finish(episodes=len(records))
    files = [*outputs, "run.json"]
    return RunResult(folder.path, rows, files)
