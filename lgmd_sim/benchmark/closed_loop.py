"""`lgmd-sim bench closed-loop`: which detector lets a robot avoid obstacles, at what cost.

Every cell (scenario, jitter level, controller, detector) runs the same list of episode
seeds, so cells differ only in what drives the carrier. Controllers: `Straight` (no
avoidance: the floor), `Oracle` (the manoeuvre triggered by ground truth: the ceiling,
and the check that the manoeuvre can avoid at all) and `ReactiveAvoid` with each detector
(an LGMD model and preset) and each way of choosing the side to turn away to
(`ClosedLoopConfig.sides`). Per episode one record (``DIR/records/<key>.json``, gathered
into ``DIR/episodes.csv``); per cell the rates with 95% Wilson intervals
(``DIR/summary.csv``, ``DIR/summary.md``); and figures (``DIR/*.png``).

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
from lgmd_sim.core.fileio import atomic_folder_outputs
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.core.runs import RunFolder, RunResult
from lgmd_sim.envs.zone import CRUISE, FALSE_ALARM_HORIZON

__all__ = ["ClosedLoopConfig", "run"]


@dataclass(frozen=True)
class ClosedLoopConfig:
    """What a closed-loop benchmark runs, checked when it is made (a bad value raises a
    one-line ValueError naming it).

    Attributes:
        scenarios: catalogue scenario names (`lgmd-sim envs`).
        jitter: jitter levels; every cell runs at each.
        controllers: names of `lgmd_sim.controllers.available()` or "package.module:Class"
            specs; one driven by a model gets a cell per detector.
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
        top_views: how many of the seeds, the first ones, the trajectories figure draws
            from above (a row of panels each).
    """

    scenarios: tuple[str, ...] = ("RoughTerrainObstacles",)
    jitter: tuple[float, ...] = (0.0, 1.0, 2.0)
    controllers: tuple[str, ...] = ("straight", "oracle", "reactive")
    detectors: tuple[tuple[str, str], ...] | None = None
    seeds: int = 50
    first_seed: int = 1000
    resolution: str | tuple[int, int] = "rl"
    cruise: float = CRUISE
    horizon: float = FALSE_ALARM_HORIZON
    extra: tuple[Cell, ...] = ()
    sides: tuple[str, ...] = (DEFAULT_SIDE,)
    top_views: int = 1

    def __post_init__(self) -> None:
        from lgmd_sim.envs.catalogue import scenarios

        def set_(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        set_("scenarios", tuple(options.names(self.scenarios, list(scenarios()),
                                              "scenario(s)")))
        set_("controllers", tuple(options.controller_names(self.controllers)
                                  if self.controllers else ()))
        set_("jitter", tuple(float(j) for j in self.jitter))
        options.check_jitter(self.jitter)
        set_("detectors", options.detectors("all") if self.detectors is None
             else options.check_detectors(self.detectors))
        options.check_positive(self.seeds, "--seeds", integer=True)
        options.check_positive(self.top_views, "--top-views", integer=True)
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


def _check_side(side: str) -> None:
    """ValueError naming --sides where `side` is not a value of ReactiveParams.side."""
    from lgmd_sim.controllers.avoid import ReactiveParams

    try:
        ReactiveParams().replace(side=side)
    except ValueError as exc:
        raise ValueError(f"--sides {side!r}: {exc}") from None


def run(config: ClosedLoopConfig, out: str | Path, options: RunOptions = RunOptions()
        ) -> RunResult:
    """Run (or resume) the benchmark of `config` in folder `out`; write its tables and
    figures; return the summary rows (one per cell, as in summary.csv) and the files.

    Args:
        config: what runs.
        out: the run folder: new, empty, or (with ``options.resume``) holding this
            configuration's run, whose finished episodes are kept.
        options: how it runs (workers, Ray, progress, resume, the command line).
    """
    from lgmd_sim.benchmark import figures
    from lgmd_sim.models.check import preflight

    cells = config.cells()
    preflight((c.model, c.preset) for c in cells if c.model)
    seeds = config.seed_list
    folder = RunFolder(out, config.as_json(), options.command, resume=options.resume)
    done = folder.done()
    episode_options = {"resolution": config.resolution, "cruise": config.cruise,
                       "horizon": config.horizon}
    jobs = [Job(cell.key(seed), episode, {"cell": cell, "seed": seed, **episode_options,
                                         "top_view": seed in seeds[:config.top_views]})
            for cell in cells for seed in seeds if cell.key(seed) not in done]
    run_jobs(jobs, lambda job, record: folder.store(job.key, record), options,
             desc="closed-loop")
    records = folder.records([cell.key(seed) for cell in cells for seed in seeds],
                             RECORD_FIELDS)
    examples = [{**r, "cell": cell_of(r).label} for r in records if "top_view" in r]
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
