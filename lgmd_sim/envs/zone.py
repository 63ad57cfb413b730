"""The Oracle's trigger zone: when a threat of the ground truth counts as close.

It lives here, below the controllers, so that one definition serves the Oracle
(`lgmd_sim.controllers.avoid.OracleParams` derives from `TriggerZone`), the benchmark's
encounters and the environment's ``proximity_penalty``; the environments cannot import
the controllers (those import the policies, which import the environments).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from lgmd_sim.core.params import CheckedParams, in_range, param, positive

__all__ = ["CRUISE", "FALSE_ALARM_HORIZON", "ORACLE_TUNED", "TriggerZone", "in_trigger_zone"]

#: The rationale of the Oracle's tuned defaults (its zone's, its manoeuvre's, its cruise).
ORACLE_TUNED = "design: tuned so that Oracle avoids the obstacles of RoughTerrainObstacles"
#: The Oracle's cruise, every cruising controller's default and every job's: the forward
#: action in [-1, 1], a fraction of the carrier's top speed (ORACLE_TUNED).
CRUISE = 0.6
#: An alarm in closed loop is false when no threat is within this time to collision (s),
#: twice the Oracle's trigger horizon: every job's default (design).
FALSE_ALARM_HORIZON = 2.0


@dataclass(frozen=True)
class TriggerZone(CheckedParams):
    """The zone's bounds; its defaults are the Oracle's."""

    horizon: float = param(1.0, ORACLE_TUNED, check=positive,
                           doc="trigger when the threat's time to collision is below this (s)")
    clearance: float = param(0.25, ORACLE_TUNED, check=in_range(0.0, 10.0),
                             doc="... or when it is nearer than this (m)")
    ahead: float = param(90.0, ORACLE_TUNED, check=in_range(0.0, 180.0),
                         doc="... and its bearing within this many degrees of straight ahead")


def in_trigger_zone(info: Mapping[str, Any], zone: TriggerZone) -> bool:
    """Whether the frame's threat is in `zone`: its time to collision
    (``info["threat_ttc"]``) below ``horizon`` or its distance (``info["threat_distance"]``)
    below ``clearance``, with its bearing (``info["threat_bearing"]``, radians) within
    ``ahead`` degrees of straight ahead. The benchmark's encounters are this zone too
    (`lgmd_sim.benchmark.encounters`)."""
    near = info["threat_ttc"] < zone.horizon or info["threat_distance"] < zone.clearance
    return bool(near and abs(math.degrees(info["threat_bearing"])) <= zone.ahead)
