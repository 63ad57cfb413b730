"""`Straight`: drive at cruise speed towards the goal, with no avoidance."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.controllers.base import Controller
from lgmd_sim.core.params import CheckedParams, in_range, non_negative, param

DESIGN = "design choice"


@dataclass(frozen=True)
class StraightParams(CheckedParams):
    cruise: float = param(1.0, DESIGN, check=in_range(-1.0, 1.0),
                          doc="forward action (a fraction of the carrier's max_speed)")
    heading_gain: float = param(1.5, DESIGN, check=non_negative,
                                doc="turn action per radian of goal bearing (0: never turn)")


class Straight(Controller):
    """Cruise towards the goal: turn = heading_gain x goal bearing, clipped to [-1, 1].

    Reads ``info["goal_bearing"]`` where the scenario has a goal; without one it drives
    straight ahead. Never avoids anything: the baseline that collides.
    """

    Params = StraightParams
    params: StraightParams
    manoeuvring = False  # it never does

    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        p = self.params
        turn = float(np.clip(p.heading_gain * info.get("goal_bearing", 0.0), -1.0, 1.0))
        return np.array([p.cruise, turn], np.float32)
