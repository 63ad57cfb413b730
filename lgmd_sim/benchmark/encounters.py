"""Encounters of an episode: when a threat came close, and whether the robot got away.

The definition (the arena task's "avoidance success rate", as the literature reports it):

- The trigger zone is the Oracle's (`lgmd_sim.envs.zone.TriggerZone` at its defaults): a
  threat is in it when its time to collision is below ``horizon`` (1 s) or
  it is nearer than ``clearance`` (0.25 m), with its bearing within ``ahead`` (90
  degrees) of straight ahead (``info["threat_ttc"]``, ``["threat_distance"]``,
  ``["threat_bearing"]``).
- An encounter is a run of frames with a threat in the zone; runs less than `MERGE_GAP`
  seconds apart are one encounter.
- A collision is a run of frames in contact (``info["collision"]``), runs less than
  `MERGE_GAP` apart merged; it counts at its onset.
- An encounter is avoided when the carrier is in contact at no frame during it or within
  `MERGE_GAP` after it: a collision still going on when it starts fails it too (a robot
  pressed against a wall, turning on the spot, leaves the zone and comes back touching
  it). A collision during no encounter (something hit from the side or behind) is a
  failed encounter of its own, so that avoided / encounters never hides a collision.
- An encounter without a collision that the episode ends in, or less than `MERGE_GAP`
  after, has no outcome yet (the episode ended, not the encounter) and is left out.

Each encounter keeps where the carrier was at its onset, for the figures.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from lgmd_sim.envs.zone import TriggerZone, in_trigger_zone

__all__ = ["LEGEND", "MERGE_GAP", "Encounter", "collision_onsets", "encounters", "runs"]

#: Zone or contact runs closer than this (s) are one: a threat's time to collision
#: flickers across the horizon as the chassis rocks on rough ground, and a chassis
#: scraping along a wall loses contact for a frame or two; neither is a new event.
MERGE_GAP = 0.3

_ZONE = TriggerZone()
#: The definition in one line, for the summary's legend.
LEGEND = (f"encounter: a threat entering the Oracle's trigger zone (time to collision "
          f"< {_ZONE.horizon:g} s or nearer than {_ZONE.clearance:g} m, within "
          f"{_ZONE.ahead:g} degrees of ahead), runs < {MERGE_GAP:g} s apart merged; avoided: "
          f"no contact during it or within {MERGE_GAP:g} s after; a collision outside "
          "every encounter counts as a failed one")


@dataclass(frozen=True)
class Encounter:
    """One encounter: its first and last frames (those in contact, for a collision during
    no encounter), where the carrier was at its onset (m) and whether it was avoided."""

    start: int
    end: int
    x: float
    y: float
    avoided: bool


def runs(flags: Sequence[bool], times: Sequence[float], gap: float = MERGE_GAP
         ) -> list[tuple[int, int]]:
    """(first, last) frame of each run of true flags, runs less than `gap` seconds apart
    merged (0: only adjacent frames)."""
    found: list[tuple[int, int]] = []
    for i, flag in enumerate(flags):
        if not flag:
            continue
        if found and (found[-1][1] == i - 1 or times[i] - times[found[-1][1]] < gap):
            found[-1] = (found[-1][0], i)
        else:
            found.append((i, i))
    return found


def _collisions(infos: Sequence[Mapping[str, Any]]) -> list[tuple[int, int]]:
    """The first and last frame in contact of each collision."""
    return runs([bool(i["collision"]) for i in infos], [i["time"] for i in infos])


def collision_onsets(infos: Sequence[Mapping[str, Any]]) -> list[int]:
    """The frames where collisions start."""
    return [start for start, _ in _collisions(infos)]


def encounters(infos: Sequence[Mapping[str, Any]], zone: TriggerZone = _ZONE
               ) -> list[Encounter]:
    """The encounters of an episode (its per-frame infos), in order of onset, of threats
    in `zone` (by default the Oracle's)."""
    times = [i["time"] for i in infos]
    contacts = _collisions(infos)
    claimed: set[tuple[int, int]] = set()
    found = []

    def at(frame: int, end: int, avoided: bool) -> Encounter:
        x, y = infos[frame]["carrier_pos"][:2]
        return Encounter(frame, end, float(x), float(y), avoided)

    for start, end in runs([in_trigger_zone(i, zone) for i in infos], times):
        after = times[end] + MERGE_GAP
        hits = {c for c in contacts if times[c[0]] < after and times[c[1]] >= times[start]}
        claimed |= hits
        if hits or times[-1] - times[end] >= MERGE_GAP:  # else its outcome was never seen
            found.append(at(start, end, not hits))
    found += [at(first, last, False) for first, last in contacts if (first, last) not in claimed]
    return sorted(found, key=lambda e: e.start)
