"""What the leaderboard checks of a result before it ranks it: every score and interval is
recomputed from the stored per-seed parts, and every number it shows is range-checked, so a
result file claims nothing its episodes do not hold.

The parts are the evidence (`lgmd_sim.benchmark.scores.Parts`): per seed of the protocol,
sums of per-episode (or per-clip) scores and their counts, the count fixed by the protocol
(one episode per jitter level; one clip per stimulus and level). A result whose parts are
off the protocol's seeds or counts, whose scores or intervals are not what its parts give,
whose per-level scores do not average to its track score, or whose rates lie outside
[0, 1], is refused in one line naming the file and the field.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.benchmark import scores
from lgmd_sim.benchmark.protocol import CameraTrack, DetectionTrack, Protocol

__all__ = ["TRACKS_BY_KIND", "check"]

#: The tracks an entry runs, by its kind (`lgmd_sim.benchmark.run.benchmark`); a detector
#: also runs the stimuli track of a protocol that has one.
TRACKS_BY_KIND = {"detector": ("goal", "arena", "detection"), "controller": ("goal", "arena"),
                  "policy": ("goal",)}
#: How close a stored number must be to the one recomputed (bits may differ across
#: processors in the bootstrap's sums, never by this much).
_TOLERANCE = 1e-9
#: The per-level columns shown as percentages, and those that are counts per minute.
_RATES = ("success_rate", "collision_rate", "avoidance_rate")
_PER_MINUTE = ("false_alarms_per_min", "collisions_per_min")


def _number(value: Any, where: str, low: float = -math.inf, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            math.isfinite(value) and low <= value <= high):
        bounds = f" in [{low:g}, {high:g}]" if math.isfinite(low) or math.isfinite(high) else ""
        raise ValueError(f"{where} is {str(value)[:40]}, not a finite number{bounds}")
    return float(value)


def _same(stored: Any, made: float, where: str) -> None:
    if abs(_number(stored, where) - made) > _TOLERANCE:
        raise ValueError(f"{where} is {stored:.6g}, but its parts give {made:.6g}")


def _counts(protocol: Protocol, track: str) -> list[int | None]:
    """Per seed, the denominators of a track's parts, in order (None: a count of frames,
    which the protocol does not fix): one episode per jitter level; the approaching and
    the non-approaching clips; per level, the camera's approach and clear clips and
    frames."""
    t = getattr(protocol, track)
    if isinstance(t, CameraTrack):
        return [len(t.approaching), len(t.clear), None, None] * len(t.jitter)
    if isinstance(t, DetectionTrack):
        return [len(t.approaching) * len(t.jitter), len(t.non_approach) * len(t.jitter)]
    return [1] * len(t.jitter) if protocol.version >= 2 else [len(t.jitter)]


def _levels(protocol: Protocol, track: str) -> list[float] | None:
    """The jitter levels a track's parts hold apart (version 2), or None."""
    t = getattr(protocol, track)
    if protocol.version < 2 or isinstance(t, DetectionTrack):
        return None
    return list(t.jitter)


def _parts(result: Mapping[str, Any], protocol: Protocol, tracks: tuple[str, ...]
           ) -> dict[str, scores.Parts]:
    stored = {t: p for t, p in result["parts"].items() if p is not None}
    if sorted(stored) != sorted(tracks):
        raise ValueError(f"parts holds the tracks {', '.join(sorted(stored)) or 'none'}; a "
                         f"{result['entry']['kind']} entry runs {', '.join(tracks)}")
    out = {}
    for track in tracks:
        where = f"parts.{track}"
        seeds = getattr(protocol, track).seeds
        if stored[track]["seeds"] != seeds:
            raise ValueError(f"{where}.seeds are not the protocol's {track} seeds "
                             f"({seeds[0]}-{seeds[-1]})")
        if stored[track].get("levels") != _levels(protocol, track):
            raise ValueError(f"{where}.levels are not the protocol's {track} jitter levels")
        counts = _counts(protocol, track)
        sums = stored[track]["sums"]
        if [len(row) for row in sums] != [2 * len(counts)] * len(seeds):
            raise ValueError(f"{where}.sums must hold {2 * len(counts)} numbers per seed")
        for i, row in enumerate(sums):
            for k, count in enumerate(counts):
                at = f"{where}.sums[{i}]"
                total = _number(row[2 * k + 1], at, 0.0)
                if count is not None and total != count:
                    raise ValueError(f"{at}: {row[2 * k + 1]} episodes or clips, the "
                                     f"protocol runs {count}")
                _number(row[2 * k], at, 0.0, total)
        out[track] = scores.Parts.from_json(stored[track])
    return out


def _metrics(result: Mapping[str, Any], protocol: Protocol,
             parts: Mapping[str, scores.Parts]) -> None:
    """The per-level rows of the closed-loop tracks and the detection metrics, checked in
    range and against the parts where they can be."""
    metrics = result["metrics"]
    for track, part in parts.items():
        rows = metrics.get(track)
        if not isinstance(rows, dict):
            raise ValueError(f"metrics.{track} is missing")
        if track in ("detection", "stimuli"):
            hits, approaching = part.sums[:, 0].sum(), part.sums[:, 1].sum()
            silent, other = part.sums[:, 2].sum(), part.sums[:, 3].sum()
            if isinstance(getattr(protocol, track), CameraTrack):  # every level's, summed
                level = part.sums.sum(axis=0).reshape(-1, 8)
                hits, approaching, silent, other = level[:, :4].sum(axis=0)
            _same(rows.get("hit_rate"), hits / approaching, f"metrics.{track}.hit_rate")
            _same(rows.get("false_alarm_rate"), 1 - silent / other,
                  f"metrics.{track}.false_alarm_rate")
            if rows.get("auc") is not None:
                _number(rows["auc"], f"metrics.{track}.auc", 0.0, 1.0)
            continue
        levels = [f"{j:g}" for j in getattr(protocol, track).jitter]
        if sorted(rows) != sorted(levels):
            raise ValueError(f"metrics.{track} holds the jitter levels {', '.join(rows)}, "
                             f"the protocol runs {', '.join(levels)}")
        level_scores = []
        for level in levels:
            row, at = rows[level], f"metrics.{track}.{level}"
            if not isinstance(row, dict):
                raise ValueError(f"{at} is not a JSON object")
            level_scores.append(_number(row.get("score"), f"{at}.score", 0.0, 1.0))
            for key in _RATES:
                if row.get(key) is not None:
                    _number(row[key], f"{at}.{key}", 0.0, 1.0)
            for key in _PER_MINUTE:
                if row.get(key) is not None:
                    _number(row[key], f"{at}.{key}", 0.0)
        # each level runs the same seeds, so the track's score is the levels' mean
        _same(float(np.mean(level_scores)), part.score(),
              f"metrics.{track}: the levels' mean score")


def check(result: Mapping[str, Any], protocol: Protocol) -> None:
    """Refuse `result` (of `protocol`, shape-checked by `lgmd_sim.benchmark.leaderboard.
    load_result`) unless its scores and intervals are what its parts give and every number
    the leaderboard shows is in range.

    Raises:
        ValueError: the first field that is not (its dotted name, what it holds, what its
            parts give).
    """
    from lgmd_sim.benchmark.entries import Entry

    entry = result["entry"]
    tracks = TRACKS_BY_KIND.get(entry["kind"])
    if tracks is None:
        raise ValueError(f"entry.kind is {entry['kind']!r}, none of {', '.join(TRACKS_BY_KIND)}")
    if entry["kind"] == "detector" and protocol.stimuli is not None:
        tracks = (*tracks, "stimuli")
    policy = entry.get("policy")
    label = Entry(entry["spec"], entry["kind"], entry.get("controller") or "",
                  entry.get("model"), entry.get("preset"), entry.get("side") or "halves",
                  Path(policy) if isinstance(policy, str) else None).label
    if label != entry["label"]:
        raise ValueError(f"entry.label is {entry['label']!r}, but its entry is {label!r}")
    parts = _parts(result, protocol, tracks)
    summary = scores.summarise(parts, protocol.bootstrap, protocol.bootstrap_seed)
    claimed = {k: v for k, v in result["scores"].items() if v is not None}
    if sorted(claimed) != sorted(summary.scores):
        raise ValueError(f"scores holds {', '.join(sorted(claimed))}; its parts give "
                         f"{', '.join(sorted(summary.scores))}")
    intervals = result["intervals"]
    for key, value in summary.scores.items():
        _same(claimed[key], value, f"scores.{key}")
        pair = intervals.get(key)
        if not (isinstance(pair, list) and len(pair) == 2):
            raise ValueError(f"intervals.{key} is not a [low, high] pair")
        for stored, made in zip(pair, summary.intervals[key], strict=True):
            _same(stored, made, f"intervals.{key}")
    _metrics(result, protocol, parts)
    _number(result["timing"]["wall_time_s"], "timing.wall_time_s", 0.0)
