"""`lgmd-sim bench closed-loop`: which detector lets a robot avoid obstacles, at what cost.

Every cell (scenario, jitter level, controller, detector) runs the same list of episode
seeds, so cells differ only in what drives the carrier. Controllers: `Straight` (no
avoidance: the floor), `Oracle` (the manoeuvre triggered by ground truth: the ceiling,
and the check that the manoeuvre can avoid at all) and `ReactiveAvoid` with each detector
(an LGMD model and preset) and each way of choosing the side to turn away to
(`ClosedLoopConfig.sides`). Per episode one record (``DIR/records/<key>.json``, gathered
into ``DIR/episodes.csv``); per cell the rates with 95% Wilson intervals
(``DIR/summary.csv``, ``DIR/summary.md``); and figures (``DIR/*.png``), which
`lgmd-sim benchmark`, showing none, leaves out.

`lgmd_sim.benchmark.episode` runs one episode and says what its record holds (alarms, false
alarms, lead time, the two kinds of task); `lgmd_sim.benchmark.summary` makes the summary and
the tables.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lgmd_sim.benchmark.episode import DEFAULT_SIDE, RECORD_FIELDS, Cell, episode, plan
from lgmd_sim.benchmark.summary import cell_of, summarise, write_tables
from lgmd_sim.controllers import options
from lgmd_sim.core.configfile import setting
from lgmd_sim.core.fileio import atomic_folder_outputs
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.core.params import Check, checked, count, in_range, positive, seed, tuple_of
from lgmd_sim.core.runs import RunFolder, RunResult
from lgmd_sim.envs.zone import CRUISE, FALSE_ALARM_HORIZON

__all__ = ["ClosedLoopConfig", "ClosedLoopResult", "run"]


@dataclass(frozen=True)
class ClosedLoopConfig:
    """What a closed-loop benchmark runs, checked when it is made (a bad value raises a
    one-line ValueError naming it). Each field is declared with its meaning
    (`lgmd_sim.core.configfile.setting`): the command line's options and --config keys.
    """

    scenarios: tuple[str, ...] = setting(
        ("RoughTerrainObstacles",), "catalogue scenario names (`lgmd-sim envs`)")
    jitter: tuple[float, ...] = setting((0.0, 1.0, 2.0),
                                        "jitter levels; every cell runs at each")
    controllers: tuple[str, ...] = setting(
        ("straight", "oracle", "reactive"),
        "controllers: straight (no avoidance), oracle (the avoidance manoeuvre triggered by "
        "ground truth), reactive (the manoeuvre triggered by an LGMD model's alarm, a cell "
        "per detector and side), or a plug-in's package.module:Class")
    detectors: tuple[tuple[str, str], ...] | None = setting(
        None, "(model, preset) pairs of the cells driven by a model, presets with any front "
        'ends ([["lgmd1", "published+image"]]); unset: every model at its default preset')
    seeds: int = setting(50, "episodes per cell, seeded first_seed, first_seed + 1, ...")
    first_seed: int = setting(1000, "the first episode seed (1000 and up are never a "
                              "training or validation seed of `lgmd-sim train`)")
    resolution: str | tuple[int, int] = setting(
        "rl", "frame size: rl (120x160), paper (270x480), small or HxW")
    cruise: float = setting(CRUISE, "forward action of every controller while cruising")
    horizon: float = setting(FALSE_ALARM_HORIZON, "an alarm is false when no obstacle is "
                             "within this time to collision (s)")
    extra: tuple[Cell, ...] = setting((), "further cells run beside the planned ones on the "
                                      "same seeds (a trained policy's: "
                                      "`lgmd_sim.training.evaluate`)", in_file=False)
    sides: tuple[str, ...] = setting(
        (DEFAULT_SIDE,), "how the reactive controller chooses the side to turn away to, "
        'each a cell of its own: "halves" (one LGMD over the whole view, the side from its '
        'S layer\'s halves) or "eyes" (two LGMDs over overlapping left and right parts of '
        "the view, away from the more excited)")
    top_views: int = setting(1, "how many of the seeds, the first ones, trajectories.png "
                             "draws from above, a row of panels each")

    def __post_init__(self) -> None:
        from lgmd_sim.envs.catalogue import scenarios

        def set_(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        set_("scenarios", tuple(options.names(self.scenarios, list(scenarios()),
                                              "scenario(s)")))
        set_("controllers", tuple(options.controller_names(self.controllers)
                                  if self.controllers else ()))
        set_("jitter", tuple(float(j) for j in self.jitter))
        checked("jitter", self.jitter, options.jitter_list)
        set_("detectors", options.detectors("all") if self.detectors is None
             else options.check_detectors(self.detectors))
        checked("seeds", self.seeds, count)
        checked("top_views", self.top_views, count)
        checked("first_seed", self.first_seed, seed)
        set_("resolution", options.resolution(self.resolution))
        checked("cruise", self.cruise, in_range(-1, 1))
        checked("horizon", self.horizon, positive)
        set_("extra", tuple(self.extra))
        set_("sides", tuple(dict.fromkeys(self.sides)))
        checked("sides", self.sides, tuple_of(_side_check(), min_length=1))
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

    @classmethod
    def from_json(cls, config: dict[str, Any]) -> ClosedLoopConfig:
        """The configuration a run folder's run.json records (`as_json`'s inverse)."""
        extra = tuple(Cell(e["scenario"], float(e["jitter"]), e["controller"],
                           e["model"], e["preset"],
                           params=tuple(e["params"].items()), tag=e["tag"])
                      for e in config["extra"])
        return cls(
            scenarios=tuple(config["scenarios"]), jitter=tuple(config["jitter"]),
            controllers=tuple(config["controllers"]),
            detectors=tuple(tuple(d) for d in config["detectors"]),
            first_seed=config["seeds"][0], seeds=config["seeds"][1],
            resolution=config["resolution"], cruise=config["cruise"],
            horizon=config["horizon"], extra=extra,
            sides=tuple(config["sides"]), top_views=config["top_views"])

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
        # the sides only where a cell takes one (they make no other cell); the default
        # first, then by name: the cells' order is not the run's identity
        sided = any("side" in controller_class(c).Params.names() for c in self.controllers)
        out["sides"] = sorted(self.sides if sided else (DEFAULT_SIDE,),
                              key=lambda side: (side != DEFAULT_SIDE, side))
        out["top_views"] = self.top_views
        out["extra"] = [{"scenario": c.scenario, "jitter": c.jitter, "controller": c.controller,
                         "model": c.model, "preset": c.preset, "params": dict(c.params),
                         "tag": c.tag} for c in self.extra]
        # every parameter of every detector a cell runs, as its preset resolves today: a
        # preset recalibrated (or a default changed) since the run began is another run
        detectors = sorted({(c.model, c.preset) for c in self.cells() if c.model})
        if detectors:
            out["detector_params"] = {f"{m}/{p}": _params(m, p) for m, p in detectors}
        return out


def _params(model: str, preset: str) -> dict[str, Any]:
    from lgmd_sim import models

    return dataclasses.asdict(models.make(model, preset=preset).params)


def _side_check() -> Check:
    """The check of ReactiveParams.side, the reactive controller's own."""
    from lgmd_sim.controllers.avoid import ReactiveParams

    return next(f.metadata["check"] for f in dataclasses.fields(ReactiveParams)
                if f.name == "side")


@dataclass(frozen=True)
class ClosedLoopResult(RunResult):
    """A closed-loop run's `RunResult` and the records its rows summarise: one per
    episode, in the order of their keys (`Cell.key`), without their top views."""

    records: list[dict[str, Any]]


def run(config: ClosedLoopConfig, out: str | Path, options: RunOptions = RunOptions(), *,
        figures: bool = True, preflighted: bool = False) -> ClosedLoopResult:
    """Run (or resume) the benchmark of `config` in folder `out`; write its tables and
    figures; return the summary rows (one per cell, as in summary.csv), the episodes'
    records and the files.

    Args:
        config: what runs.
        out: the run folder: new, empty, or (with ``options.resume``) holding this
            configuration's run, whose finished episodes are kept.
        options: how it runs (workers, Ray, progress, resume, the command line).
        figures: draw the figures (False: the tables only, for a caller that shows none:
            `lgmd-sim benchmark`).
        preflighted: the caller has run the preflight on the cells' detectors
            (`lgmd_sim.models.check.preflight`) with its other inputs: not again here.
    """
    from lgmd_sim.benchmark import figures as plots
    from lgmd_sim.models.check import preflight
    from lgmd_sim.models.presets import carrying_presets

    cells = config.cells()
    if not preflighted:
        preflight((c.model, c.preset) for c in cells if c.model)
    seeds = config.seed_list
    folder = RunFolder(out, config.as_json(), options.command, resume=options.resume)
    done = folder.done()
    episode_options = {"resolution": config.resolution, "cruise": config.cruise,
                       "horizon": config.horizon}
    # a presets file that stands in for the user's (a calibrated benchmark entry's) goes
    # with the jobs to the workers that build their detectors
    play = carrying_presets(episode)
    jobs = [Job(cell.key(seed), play, {"cell": cell, "seed": seed, **episode_options,
                                      "top_view": seed in seeds[:config.top_views]})
            for cell in cells for seed in seeds if cell.key(seed) not in done]
    run_jobs(jobs, lambda job, record: folder.store(job.key, record), options,
             desc="closed-loop")
    records = folder.records([cell.key(seed) for cell in cells for seed in seeds],
                             RECORD_FIELDS)
    examples = [{**r, "cell": cell_of(r).label} for r in records if "top_view" in r]
    records = [{k: v for k, v in r.items() if k != "top_view"} for r in records]
    rows = summarise(records)
    outputs = ["episodes.csv", "summary.csv", "summary.md"]
    if figures:
        outputs += plots.closed_loop_figures(rows, examples)
    with atomic_folder_outputs(folder.path, outputs) as staging:  # all of them, or none
        write_tables(staging, records, rows)
        if figures:
            plots.closed_loop(staging, rows, examples)
    folder.finish(episodes=len(records))
    return ClosedLoopResult(folder.path, rows, [*outputs, "run.json"], records)
