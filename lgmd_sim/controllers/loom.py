"""`LoomSteer`: steer by two LGMD eyes all the time, not by one alarm and a timer.

`ReactiveAvoid` runs a fixed manoeuvre on an alarm (turn 0.7 s, drive on 0.8 s) and then
heads for the goal whatever it sees: in about half of its collisions the last alarm came
more than 1.15 s before the hit, and the robot had turned back into the obstacle
(docs/experiments/results-log.md, the robot's closed-loop targets). The LGMD robots steer
otherwise: Gary2017's testbed turns away from the more excited of two overlapping LGMDs,
the Colias robots keep turning while the neuron stays excited. `LoomSteer` does both,
with every frame's potentials:

- each eye's potential, low-passed, as an excitation: 0 at the episode's first frame
  (nothing has moved yet), 1 at the model's threshold;
- cruising: the turn towards the goal, plus a turn away from the more excited eye in
  proportion to the difference; the speed shed in proportion to the larger excitation;
- on an alarm (the model's own rule, of either eye): brake and turn away from the more
  excited eye, and go on turning while the larger excitation stays above ``release`` or
  an alarm came within ``hold``;
- after an avoidance, for ``memory`` seconds, the turn back to the goal never turns
  towards the side it avoided: an obstacle passed at the side leaves the 70-degree view
  before the chassis clears it.

What each part does, measured, and each detector's constants (`TUNED`):
docs/experiments/loom-steer.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from lgmd_sim.controllers.base import Controller
from lgmd_sim.controllers.detector import DetectorParams, eye_overlap, eyes
from lgmd_sim.controllers.straight import StraightParams
from lgmd_sim.core.params import in_range, non_negative, param
from lgmd_sim.envs.wrappers.frames import check_frame_space
from lgmd_sim.envs.zone import CRUISE, ORACLE_TUNED

__all__ = ["LoomParams", "LoomSteer"]

#: Where the steering constants come from: a design; each detector's search (the same
#: budget for every one) then chose its own (`TUNED`).
SEARCHED = ("design; per detector, chosen on search seeds of RoughTerrainObstacles at jitter 1 "
            "(TUNED, docs/experiments/loom-steer.md)")
#: The constants each detector's search chose over the defaults, by "model/preset"
#: (docs/experiments/loom-steer.md, made by docs/experiments/tools/loom_search.py: 16
#: settings in two rounds, 16 search seeds each); a detector without an entry drives at
#: the defaults, and a caller's own values come on top.
TUNED: dict[str, dict[str, float]] = {
    "lgmd1/robot-image": {"steer_gain": 1.5},
    "lgmd2/robot-imu": {"steer_gain": 0.0},
    "f_on/robot-image": {"steer_gain": 0.0},
    "feedback/robot-image": {"steer_gain": 1.5},
    "feedback/robot-open-loop-image": {"release": 0.8, "hold": 0.2},
}


@dataclass(frozen=True)
class LoomParams(DetectorParams, StraightParams):
    """The detector, its two eyes, and how their excitation steers."""

    cruise: float = param(CRUISE, ORACLE_TUNED, check=in_range(-1.0, 1.0),
                          doc="forward action with nothing excited (fraction of max_speed)")
    eye_overlap: float = eye_overlap()
    smooth: float = param(0.1, SEARCHED, check=non_negative,
                          doc="time constant (s) of the low-pass on each eye's potential: "
                              "a shake's one-frame surge moves the robot little")
    steer_gain: float = param(1.0, SEARCHED, check=non_negative,
                              doc="turn away from the more excited eye per unit of the "
                                  "eyes' difference in excitation, while cruising")
    slow: float = param(0.5, SEARCHED, check=in_range(0.0, 1.0),
                        doc="share of the cruise shed at the threshold's excitation (in "
                            "proportion below it)")
    avoid_turn: float = param(1.0, ORACLE_TUNED, check=in_range(0.0, 1.0),
                              doc="turn action while avoiding, away from the more excited eye")
    avoid_speed: float = param(-0.1, ORACLE_TUNED, check=in_range(-1.0, 1.0),
                               doc="forward action while avoiding (the Oracle's brake)")
    hold: float = param(0.4, SEARCHED, check=non_negative,
                        doc="an avoidance lasts at least this long (s) after the last alarm")
    release: float = param(0.5, SEARCHED, check=in_range(0.0, 1.0),
                           doc="... and while the larger excitation stays at or above this "
                               "(1: the threshold)")
    memory: float = param(1.5, SEARCHED, check=non_negative,
                          doc="for this long (s) after an avoidance, the turn back to the "
                              "goal never turns towards the side it avoided")


class LoomSteer(Controller):
    """Steer by the potentials of two LGMDs over the left and right of the view (the
    module's doc says how). ``potential`` is the last frame's larger potential, ``alarm``
    whether either eye alarmed, ``manoeuvring`` whether it is avoiding. Reads
    ``obs["frame"]`` (every frame goes through the model), ``info["time"]``,
    ``info["goal_bearing"]`` where the scenario has a goal, and for a model stabilized
    by the pose or the IMU the camera's rotation in ``info``."""

    Params = LoomParams
    params: LoomParams
    uses_model = True

    def __init__(self, **params: Any) -> None:
        p = self.resolve(**params)  # checked before the model is made from it
        self.model = eyes(p, p.eye_overlap)
        super().__init__(**params)

    @classmethod
    def resolve(cls, **params: Any) -> LoomParams:
        """The parameters it runs with: its detector's `TUNED` constants, then `params`."""
        p = cls.Params(**params)
        return cls.Params(**{**TUNED.get(f"{p.model}/{p.preset}", {}), **params})

    def wrap_env(self, env: gym.Env) -> gym.Env:
        check_frame_space(env.observation_space)
        return super().wrap_env(env)

    def reset(self) -> None:
        self.model.reset()
        self.alarm = False
        self.manoeuvring = False
        self.potential = 0.5
        self.excitation = np.zeros(2)  # (left, right)
        self._smoothed: np.ndarray | None = None
        self._rest = 0.0
        self._time = 0.0
        self._away = 0.0  # the turn of the avoidance under way, or of the last one
        self._last_alarm = -np.inf
        self._ended = -np.inf  # when the last avoidance ended

    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        p, now = self.params, float(info["time"])
        out = self.model.step(obs["frame"], rotation=self.model.rotation_from(info))
        x = self._excite(np.asarray(out.potential, np.float64), now)
        self.potential = float(np.max(out.potential))
        self.alarm = bool(np.any(out.alarm))
        if self.alarm:
            self._last_alarm = now
            if not self.manoeuvring:  # away from the more excited eye: the left, turn right
                self._away = -p.avoid_turn if x[0] > x[1] else p.avoid_turn
            self.manoeuvring = True
        elif (self.manoeuvring and now - self._last_alarm >= p.hold
              and x.max() < p.release):
            self.manoeuvring, self._ended = False, now
        if self.manoeuvring:
            return np.array([p.avoid_speed, self._away], np.float32)
        goal = p.heading_gain * float(info.get("goal_bearing", 0.0))
        if now - self._ended < p.memory and goal * self._away < 0:
            goal = 0.0  # back towards the side just avoided: not yet
        turn = goal + p.steer_gain * (x[1] - x[0])
        speed = p.cruise * (1.0 - p.slow * min(1.0, x.max()))
        return np.array([speed, float(np.clip(turn, -1.0, 1.0))], np.float32)

    def _excite(self, potential: np.ndarray, now: float) -> np.ndarray:
        """Each eye's low-passed potential, 0 at rest (the first frame's) and 1 at the
        threshold, clipped to [0, 2]."""
        if self._smoothed is None:
            self._smoothed, self._rest = potential.copy(), float(potential.min())
        else:
            dt = max(now - self._time, 0.0)
            keep = 0.0 if self.params.smooth == 0 else np.exp(-dt / self.params.smooth)
            self._smoothed = keep * self._smoothed + (1.0 - keep) * potential
        self._time = now
        span = max(self.model.threshold - self._rest, 1e-9)
        self.excitation = np.clip((self._smoothed - self._rest) / span, 0.0, 2.0)
        return self.excitation
