"""Encounters of an episode: when a threat came close, and whether the robot got away.

The definition (the arena task's "avoidance success rate", as the literature reports it):

- The trigger zone is the Oracle's (`lgmd_sim.controllers.avoid.OracleParams` at its
  defaults): a threat is in it when its time to collision is below ``horizon`` (1 s) or
  it is nearer than ``clearance`` (0.25 m), with its bearing within ``ahead`` (90
  degrees) of straight ahead (``info["threat_ttc"]``, ``["threat_distance"]``,
  ``["threat_bearing"]``).
- An encounter is a run of frames with a threat in the zone; runs less than `MERGE_GAP`
  seconds apart are one encounter.
- A collision is a run of frames in contact (``info["collision"]``), runs less than
  `MERGE_GAP` apart merged; it counts at its onset.
- An encounter is avoided when no collision starts during it or within `MERGE_GAP` after
  it. A collision that starts outside every encounter (something hit from the side or
  behind) is a failed encounter of its own, so that avoided / encounters never hides a
  collision.
- An encounter still in the zone at the episode's last frame without a collision has no
  outcome yet (the episode ended, not the encounter) and is left out.

Each encounter keeps where the carrier was at its onset, for the figures.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from lgmd_sim.controllers.avoid import OracleParams

__all__ = ["LEGEND", "MERGE_GAP", "Encounter", "collision_onsets", "encounters", "in_zone"]

#: Zone or contact runs closer than this (s) are one: a threat's time to collision
#: flickers across the horizon as the chassis rocks on rough ground, and a chassis
#: scraping along a wall loses contact for a frame or two; neither is a new event.
MERGE_GAP = 0.3

_ZONE = OracleParams()
#: The definition in one line, for the summary's legend.
LEGEND = (f"encounter: a threat entering the Oracle's trigger zone (time to collision "
          f"< {_ZONE.horizon:g} s or nearer than {_ZONE.clearance:g} m, within "
          f"{_ZONE.ahead:g} degrees of ahead), runs < {MERGE_GAP:g} s apart merged; avoided: "
          f"no collision during it or within {MERGE_GAP:g} s after; a collision outside "
          "every encounter counts as a failed one")


@dataclass(frozen=True)
class Encounter:
    """One encounter: its first and last frames, where the carrier was at its onset (m)
    and whether it was avoided."""

    start: int
    end: int
    x: float
    y: float
    avoided: bool


def in_zone(info: Mapping[str, Any], zone: OracleParams = _ZONE) -> bool:
    """Whether the frame's threat is in the trigger zone of `zone` (the Oracle's)."""
    near = info["threat_ttc"] < zone.horizon or info["threat_distance"] < zone.clearance
    return bool(near and abs(math.degrees(info["threat_bearing"])) <= zone.ahead)


def _runs(flags: Sequence[bool], times: Sequence[float]) -> list[tuple[int, int]]:
    """(first, last) frame of each run of true flags, runs less than `MERGE_GAP` apart
    merged."""
    runs: list[tuple[int, int]] = []
    for i, flag in enumerate(flags):
        if not flag:
            continue
        if runs and (runs[-1][1] == i - 1 or times[i] - times[runs[-1][1]] < MERGE_GAP):
            runs[-1] = (runs[-1][0], i)
        else:
            runs.append((i, i))
    return runs


def collision_onsets(infos: Sequence[Mapping[str, Any]]) -> list[int]:
    """The frames where collisions start."""
    times = [i["time"] for i in infos]
    return [start for start, _ in _runs([bool(i["collision"]) for i in infos], times)]


def encounters(infos: Sequence[Mapping[str, Any]], zone: OracleParams = _ZONE
               ) -> list[Encounter]:
    """The encounters of an episode (its per-frame infos), in order of onset."""
    times = [i["time"] for i in infos]
    onsets = collision_onsets(infos)
    claimed: set[int] = set()
    found = []

    def at(frame: int, end: int, avoided: bool) -> Encounter:
        x, y = infos[frame]["carrier_pos"][:2]
        return Encounter(frame, end, float(x), float(y), avoided)

    for start, end in _runs([in_zone(i, zone) for i in infos], times):
        hits = {c for c in onsets if times[start] <= times[c] < times[end] + MERGE_GAP}
        claimed |= hits
        if hits or end < len(infos) - 1:  # one still open at the end has no outcome
            found.append(at(start, end, not hits))
    found += [at(c, c, False) for c in onsets if c not in claimed]
    return sorted(found, key=lambda e: e.start)
