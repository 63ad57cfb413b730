"""`lgmd-sim bench closed-loop --policies`: trained policies in the closed-loop benchmark,
beside the hand-made controllers, on the same seeds.

Each policy is a cell of its own (``Cell(scenario, jitter, "policy", params=(("path",
...),), tag=<policy name>)``) added to the benchmark's sweep (`lgmd_sim.benchmark.closed_loop`),
so it writes the same tables and figures; ``eval.md`` adds the mean distance travelled.
Every cell runs in the environment the policies were trained in (their scenario and frame
size), so the policies must share both.
"""

from __future__ import annotations

import csv
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
from lgmd_sim.benchmark.episode import Cell
from lgmd_sim.core.configfile import setting
from lgmd_sim.core.fileio import write_text_atomic
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.core.runs import RunResult
from lgmd_sim.envs.zone import CRUISE, FALSE_ALARM_HORIZON
from lgmd_sim.policies import EVAL_SEEDS, EVAL_TOP_VIEWS

__all__ = ["EvalConfig", "eval_markdown", "evaluate"]


@dataclass(frozen=True)
class EvalConfig:
    """What `evaluate` runs, checked when it is made (a bad value raises a one-line
    ValueError naming it). Each field is declared with its meaning
    (`lgmd_sim.core.configfile.setting`): ``lgmd-sim bench closed-loop --policies``'s
    options and --config keys.
    """

    policies: tuple[str, ...] = setting(
        ("shipped",), "policy folders (as `lgmd-sim train` writes them) or shipped policies' "
        "names (shipped: the default one); they must share their environment and frame "
        "size, in which every cell then runs")
    controllers: tuple[str, ...] = setting(
        ("straight", "oracle", "reactive"), "hand-made controllers beside them "
        "(`lgmd_sim.controllers`, not policy); [] for none")
    detectors: tuple[tuple[str, str], ...] | None = setting(
        None, "ReactiveAvoid's detectors, (model, preset) pairs; unset: the LGMD models the "
        "policies observe, at their presets (every model at its default preset when no "
        "policy observes one), so that the reactive cells are the bar a policy on those "
        "features must clear. The plug-in specs among them are those the policies may "
        "observe too: a policy's own choice of a spec is refused, since importing it runs "
        "its code")
    jitter: tuple[float, ...] = setting((1.0, 2.0), "jitter levels; every cell runs at each")
    seeds: int = setting(EVAL_SEEDS, "episodes per cell (`lgmd_sim.policies.EVAL_SEEDS`: "
                         "those of the evaluation a shipped policy's POLICY.md quotes)")
    first_seed: int = setting(1000, "the first episode seed (1000 and up are never a "
                              "training or validation seed of `lgmd-sim train`)")
    cruise: float = setting(CRUISE, "forward action of every controller while cruising")
    horizon: float = setting(FALSE_ALARM_HORIZON, "an alarm is false when no obstacle is "
                             "within this time to collision (s)")
    top_views: int = setting(EVAL_TOP_VIEWS, "how many of the seeds, the first ones, "
                             "trajectories.png draws from above, a row of panels each")

    def __post_init__(self) -> None:
        from lgmd_sim import controllers
        from lgmd_sim.controllers import options
        from lgmd_sim.policies import load

        hand_made = [c for c in controllers.available() if c != "policy"]

        def hand_made_class(spec: str) -> type:
            """A spec's class, unless it is the trained policies' (they are `policies`,
            each its own cell)."""
            cls = controllers.controller_class(spec)
            if issubclass(cls, controllers.controller_class("policy")):
                raise ValueError(f"unknown controller(s) {spec!r} (a trained policy is one "
                                 f"of the policies); valid: all, {', '.join(hand_made)}")
            return cls

        object.__setattr__(self, "policies", tuple(self.policies) or ("shipped",))
        object.__setattr__(self, "controllers", tuple(
            options.names(self.controllers, hand_made, "controller(s)",
                          load=hand_made_class)
            if self.controllers else ()))
        self.bench()  # the policies' configurations and every episode option, checked now
        for policy in self.policies:  # and their networks, before any run folder is made
            load(policy, self.plugins)

    @property
    def plugins(self) -> tuple[str, ...]:
        """The plug-in model specs among `detectors`, named by the user: the policies may
        observe them besides the built-in, registered and installed models."""
        from lgmd_sim import models

        return tuple(dict.fromkeys(m for m, _ in self.detectors or ()
                                   if models.origin(m) == "spec"))

    def bench(self) -> ClosedLoopConfig:
        """The closed-loop benchmark that evaluates the policies: their cells beside the
        hand-made controllers', in the environment they were trained in."""
        from lgmd_sim.controllers import options
        from lgmd_sim.core.extras import require
        from lgmd_sim.envs.catalogue import scenarios
        from lgmd_sim.policies import load_config, name_of

        require("stable_baselines3", "rl")
        loaded = [load_config(p, self.plugins) for p in self.policies]
        names = [name_of(folder) for folder, _, _ in loaded]
        if len(set(names)) < len(names):
            raise ValueError(f"two policies share a folder name ({', '.join(names)}): the "
                             "name labels a policy's cells")
        envs = {(c.env_id, str(c.resolution)) for _, c, _ in loaded}
        if len(envs) > 1:
            raise ValueError("the policies were trained in different environments or frame "
                             f"sizes ({'; '.join(' at '.join(e) for e in sorted(envs))}): "
                             "evaluate them apart")
        trained = loaded[0][1]
        # load_config refuses an environment that is not a scenario
        scenario = {s.env_id: name for name, s in scenarios().items()}[trained.env_id]
        observed = [c.model if c.preset is None else f"{c.model}/{c.preset}"
                    for _, c, _ in loaded if c.model]
        extra = tuple(Cell(scenario, float(j), "policy",
                           params=(("path", str(folder.resolve())),
                                   ("plugins", ",".join(self.plugins))), tag=name)
                      for j in self.jitter
                      for (folder, _, _), name in zip(loaded, names, strict=True))
        return ClosedLoopConfig(
            scenarios=(scenario,), jitter=self.jitter, controllers=self.controllers,
            detectors=self.detectors or (options.detectors(observed) if observed else None),
            seeds=self.seeds, first_seed=self.first_seed,
            resolution=trained.resolution, cruise=self.cruise, horizon=self.horizon,
            extra=extra, top_views=self.top_views)


def evaluate(config: EvalConfig, out: str | Path, options: RunOptions = RunOptions()
             ) -> RunResult:
    """Run the policies of `config` in the closed-loop benchmark (its tables and figures
    in `out`, see `lgmd_sim.benchmark.closed_loop.run` for the arguments), then ``eval.md``."""
    from lgmd_sim.benchmark import closed_loop

    result = closed_loop.run(config.bench(), out, options)
    write_text_atomic(result.path / "eval.md", eval_markdown(result.path))
    return RunResult(result.path, result.rows, [*result.files, "eval.md"])


def eval_markdown(folder: Path) -> str:
    """Per cell of the benchmark run in `folder`: collision and success rates (95%
    intervals) and the mean distance travelled, from its summary.csv and episodes.csv; the
    reactive cell with the fewest collisions (then the most successes) at each jitter
    level is marked as the best detector."""
    distance: dict[tuple[str, str], list[float]] = defaultdict(list)
    with (folder / "episodes.csv").open(newline="") as f:
        for r in csv.DictReader(f):
            distance[(r["jitter"], _label(r))].append(float(r["distance_m"]))
    with (folder / "summary.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    best = {}
    for r in rows:
        if r["controller"] == "reactive":
            score = (-float(r["collision_rate"]), float(r["success_rate"] or 0))
            if r["jitter"] not in best or score > best[r["jitter"]][0]:
                best[r["jitter"]] = (score, _label(r))
    lines = ["| jitter | controller | episodes | collisions % [95% CI] | success % [95% CI] "
             "| distance travelled (m, mean) | progress |", "|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        label = _label(r)
        mark = " (best detector)" if best.get(r["jitter"], (0, None))[1] == label else ""
        d = distance[(r["jitter"], label)]
        lines.append(
            f"| {float(r['jitter']):g} | {label}{mark} | {r['episodes']} | "
            f"{_pct(r, 'collision')} | {_pct(r, 'success')} | {sum(d) / len(d):.2f} | "
            f"{_fmt(r['mean_progress'])} |")
    return "\n".join(lines) + "\n"


def _label(r: dict[str, Any]) -> str:
    return Cell(r["scenario"], float(r["jitter"]), r["controller"], r["model"] or None,
                r["preset"] or None, tag=r["tag"] or None).label


def _pct(r: dict[str, str], what: str) -> str:
    if not r[f"{what}_rate"]:  # no success rate of a task without a goal
        return "-"
    rate, lo, hi = (float(r[f"{what}_rate"]), float(r[f"{what}_ci_low"]),
                    float(r[f"{what}_ci_high"]))
    return f"{100 * rate:.0f} [{100 * lo:.0f}, {100 * hi:.0f}]"


def _fmt(text: str) -> str:
    return f"{float(text):.2f}" if text else "-"
