"""One episode of one cell of the closed-loop benchmark (`lgmd_sim.benchmark.closed_loop`),
and its record: what is measured of it.

Alarms are the controller's detector firing (an LGMD alarm, or the Oracle's trigger),
counted at their onsets; an alarm is false when no obstacle is within ``horizon`` seconds
of collision at that frame (``info["threat_ttc"]``). The lead time of a collision is the
time from the last alarm onset before it; the first alarm's time to collision is the
ground truth's at the first onset.

Two kinds of task: a scenario with a goal (its infos carry ``goal_distance``), whose cells
report collision and success rates and progress; and a roam task without one (ArenaRoam:
a fixed time in a walled arena, collisions not ending the episode), whose cells report
collisions per minute, the share of encounters avoided (`lgmd_sim.benchmark.encounters`
defines them), the distance travelled against the Oracle's and the share of the time
spent manoeuvring. Every record carries both kinds of figure where they apply.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim.benchmark import encounters
from lgmd_sim.benchmark.fingerprint import Fingerprint
from lgmd_sim.controllers import options
from lgmd_sim.controllers.avoid import ReactiveParams
from lgmd_sim.core.runs import NULL, NUMBER, Maybe
from lgmd_sim.signals.metrics import alarm_onsets

if TYPE_CHECKING:
    import gymnasium as gym

    from lgmd_sim.controllers import Controller

__all__ = ["DEFAULT_SIDE", "RECORD_FIELDS", "Cell", "driven", "episode", "plan"]

#: ReactiveParams.side's default (one LGMD over the whole view, the side from its S
#: layer's halves). Cells at it carry no side parameter: the default's label and key
#: are the plain ones.
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
        "straight", "policy: ppo-feedback", "loom-steer: lgmd1/robot (slow 0)"."""
        detail = f"{self.model}/{self.preset}" if self.model else self.tag
        if self.model and self.tag:
            detail += f" ({self.tag})"
        side = f", {self.side}" if self.side else ""
        return self.controller + (f": {detail}" if detail else "") + side

    def key(self, seed: int) -> str:
        """The cell's record name for one seed (a file name: `controllers.options.file_key`)."""
        detail = "".join(f"-{part}" for part in (self.model, self.preset, self.tag) if part)
        side = f"-{self.side}" if self.side else ""
        key = f"{self.scenario}-j{self.jitter:g}-{self.controller}{detail}{side}-s{seed}"
        return options.file_key(key)


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


@contextmanager
def driven(cell: Cell, *, resolution: Any, cruise: float
           ) -> Iterator[tuple[gym.Env, Controller]]:
    """The environment of `cell` as its controller observes it, and the controller: a
    cell's episode is ``controllers.rollout(env, controller, seed)`` inside."""
    from lgmd_sim import controllers
    from lgmd_sim.envs.reuse import episode_env

    params = dict(cell.params)
    if cell.model:
        params.update(model=cell.model, preset=cell.preset)
    if "cruise" in controllers.controller_class(cell.controller).Params.names():
        params.setdefault("cruise", cruise)  # every cruising controller at the same speed
    controller = controllers.make(cell.controller, **params)
    with episode_env(cell.scenario, jitter=cell.jitter, resolution=resolution) as base:
        yield controller.wrap_env(base), controller


def episode(cell: Cell, seed: int, *, resolution: Any, cruise: float, horizon: float,
            top_view: bool = False) -> dict[str, Any]:
    """Run one episode of `cell` and measure it (a job: runs in a worker process)."""
    from lgmd_sim import controllers

    infos, alarms, manoeuvring = [], [], []
    trace = Fingerprint()
    with driven(cell, resolution=resolution, cruise=cruise) as (env, controller):
        for step in controllers.rollout(env, controller, seed=seed):
            trace.add(step.obs, step.info, step.action,
                      getattr(controller, "potential", None) if step.action is not None
                      else None)
            infos.append(step.info)
            alarms.append(step.action is not None and controller.alarm)
            if step.action is not None:
                manoeuvring.append(controller.manoeuvring)
        view = env.unwrapped.world.top_view() if top_view else None
    first, last = infos[0], infos[-1]
    xy = np.array([i["carrier_pos"][:2] for i in infos])
    times = np.array([i["time"] for i in infos])
    travelled = float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())
    onsets = alarm_onsets(alarms)
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
        "fingerprint": trace.to_json(),
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
RECORD_FIELDS = {
    "scenario": str, "jitter": NUMBER, "controller": str, "model": (str, NULL),
    "preset": (str, NULL), "tag": (str, NULL), "side": (str, NULL),
    "seed": int, "task": str, "time_s": NUMBER, "distance_m": (NUMBER, NULL),
    "collided": bool, "goal_reached": bool, "false_alarms": int,
    "progress": Maybe((NUMBER, NULL)),  # a goal task's only
    "first_alarm_ttc_s": (NUMBER, NULL), "lead_time_s": (NUMBER, NULL),
    "collisions": int, "encounters": int, "avoided": int,
    "manoeuvring_share": (NUMBER, NULL),
    "fingerprint": {"steps": int, "every": int, "chain": [str], "sha256": str},
}


def _lead_time(times: np.ndarray, onsets: np.ndarray, collision: int) -> float | None:
    """Seconds from the last alarm onset at or before the collision to the collision."""
    before = onsets[onsets <= collision] if collision >= 0 else onsets[:0]
    return _finite(times[collision] - times[before[-1]]) if len(before) else None


def _finite(x: float) -> float | None:
    """JSON-safe: None for an infinite or undefined value, else rounded."""
    x = float(x)
    return round(x, 4) if math.isfinite(x) else None
