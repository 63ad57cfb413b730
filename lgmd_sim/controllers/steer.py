"""`Steer`: the Oracle's inputs without its memory.

The Oracle (`lgmd_sim.controllers.avoid.Oracle`) times a manoeuvre once triggered: it
turns for ``avoid_time``, drives on for ``pass_time`` and ignores triggers for
``refractory``, whatever it sees meanwhile. No policy's observation holds that clock, so
no policy can copy it exactly. `Steer` acts on the current frame's ground truth alone
(the threat's distance, bearing and time to collision, the goal's bearing: what
``--obs privileged`` gives a policy), a teacher a policy without memory can match.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.controllers.base import Controller
from lgmd_sim.controllers.straight import StraightParams
from lgmd_sim.core.params import in_range, non_negative, param, positive
from lgmd_sim.envs.zone import CRUISE, ORACLE_TUNED

__all__ = ["Steer", "SteerParams"]

#: Where its constants come from: a first setting by design, `ahead` then chosen among 8
#: settings on search seeds 2000-2029 (RoughTerrainObstacles, jitter 1, no frames), by
#: docs/experiments/tools/steer_search.py.
SEARCHED = ("design, then chosen among 8 settings on search seeds 2000-2029 of "
            "RoughTerrainObstacles at jitter 1 (docs/experiments/tools/steer_search.py)")


@dataclass(frozen=True)
class SteerParams(StraightParams):
    """The cruise and heading of `Straight`, and the push away from a threat."""

    cruise: float = param(CRUISE, ORACLE_TUNED, check=in_range(-1.0, 1.0),
                          doc="forward action while no threat pushes (the Oracle's cruise)")
    ahead: float = param(90.0, SEARCHED, check=in_range(0.0, 180.0),
                         doc="a threat pushes while within this many degrees of straight "
                             "ahead")
    avoid_distance: float = param(1.2, SEARCHED, check=positive,
                                  doc="a threat nearer than this (m) pushes, the harder the "
                                      "nearer")
    avoid_ttc: float = param(1.5, SEARCHED, check=positive,
                             doc="... or one sooner than this (s) to collide")
    threat_gain: float = param(2.5, SEARCHED, check=non_negative,
                               doc="turn per unit of push, away from the threat's side")
    goal_share: float = param(0.3, SEARCHED, check=in_range(0.0, 1.0),
                              doc="share of the turn towards the goal kept while pushed")
    slow: float = param(0.35, SEARCHED, check=in_range(0.0, 1.0),
                        doc="least share of the cruise kept near a threat (at "
                            "avoid_distance and beyond: all of it)")


class Steer(Controller):
    """Head for the goal (as `Straight`); a threat ahead, near or soon, pushes the turn
    away from its side and slows the robot, in proportion to how near and how soon. Reads
    ``info["threat_distance"]``, ``["threat_bearing"]``, ``["threat_ttc"]`` and
    ``["goal_bearing"]``; keeps no state, so the same frame always gives the same
    action."""

    Params = SteerParams
    params: SteerParams
    manoeuvring = False  # True on a frame a threat pushes: reported, never read back

    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        p = self.params
        bearing, distance = float(info["threat_bearing"]), float(info["threat_distance"])
        ttc = float(info["threat_ttc"])
        turn, speed = p.heading_gain * float(info.get("goal_bearing", 0.0)), p.cruise
        self.manoeuvring = abs(math.degrees(bearing)) <= p.ahead and (
            distance < p.avoid_distance or ttc < p.avoid_ttc)
        if self.manoeuvring:
            push = (max(0.0, 1.0 - distance / p.avoid_distance)
                    + max(0.0, 1.0 - ttc / p.avoid_ttc))
            away = -1.0 if bearing > 0 else 1.0  # a threat on the left: turn right
            turn = away * p.threat_gain * push + p.goal_share * turn
            speed = p.cruise * min(1.0, max(p.slow, distance / p.avoid_distance))
        return np.array([speed, float(np.clip(turn, -1.0, 1.0))], np.float32)
