"""The declared objective of the robot calibration: an alarm while the avoidance manoeuvre
can still avoid the threat ahead, and silence while nothing threatens.

The robot's clips show it driving straight over rough ground (jitter 0, 1 and 2) at the
closed-loop benchmark's cruise: **approach** clips at a box or a wall ahead until it hits
it, **clear** clips with no obstacle in its way (open ground; obstacles and angled walls
beside its path). Each frame is judged by the ground truth of its threat, the world's
most threatening obstacle or wall (one touched in this frame, else the soonest to collide,
else the nearest: ``threat_ttc``, ``threat_bearing``):

- a **window** frame (of an approach clip) when the threat is ahead (within ``AHEAD`` =
  90 degrees of the heading, as the Oracle's trigger) and its time to collision lies in
  [``TTC_LO``, ``TTC_HI``] = [0.6, 1.15] s: the manoeuvre (braking and turning away)
  started then avoids it. The bounds are measured: the Oracle, the same manoeuvre
  triggered by the ground truth, meets the closed-loop target at jitter 1 (the goal in
  60% of the episodes or more, collisions in 15% or fewer) when it is triggered at a time
  to collision from 0.6 to 1.15 s, and at no other horizon tried (0.3 to 2.2 s, 40 seeds:
  ``docs/experiments/tools/oracle_window.py``). Later, the turn cannot clear the obstacle;
  earlier, the robot turns away from what it has not reached, again and again, and runs out of time;
- a **clear** frame when no threat is within ``HORIZON`` = 2 s, the horizon beyond which
  the closed-loop benchmark counts an alarm as false;
- neither otherwise (between the window and the horizon, or past the window).

Three parts, each a rate in [0, 1]:

- **approach**: the share of approach clips whose first alarm falls on a window frame.
  Earlier is a false alarm (the robot turns away from nothing, then ignores its detector
  for a while), later or never a miss. The first alarm is what the robot acts on.
- **clear**: the share of clear clips with no alarm at all.
- **frames**: the balanced accuracy over every frame of the set: the share of window frames
  alarmed and the share of clear frames silent, averaged (a kind of frame the set lacks
  is left out). The robot acts on every alarm, not only the first (after a manoeuvre it
  cruises on and meets the next obstacle), and the many clear frames do not outweigh the
  few window frames.

objective = mean of the parts present, in [0, 1]: a set without approach or clear clips,
or without window and clear frames, has no such part (the summary shows "-"). An alarm is
the potential above the threshold, frame by frame, as `lgmd_sim.controllers.ReactiveAvoid`
triggers on it; `ROBOT_FRAMES` judges the same clips with the video presets' rule instead
(4 frames running above the threshold, never falling).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.calibration.objective import (
    VIDEO,
    Objective,
    first_crossings,
    kind_rates,
    pack_hits,
    unpack_hits,
)
from lgmd_sim.controllers.avoid import OracleParams
from lgmd_sim.envs.zone import FALSE_ALARM_HORIZON

__all__ = ["AHEAD", "HORIZON", "KINDS", "ROBOT", "ROBOT_FRAMES", "TRUTH", "TTC_HI", "TTC_LO",
           "FrameLabel", "frame_counts", "frame_label", "hits"]

#: The window of times to collision (s) in which the robot's alarm must come.
TTC_LO, TTC_HI = 0.6, 1.15
#: No threat within this time to collision (s): a frame that must stay silent.
HORIZON: float = FALSE_ALARM_HORIZON
#: A threat is ahead within this many degrees of the heading.
AHEAD: float = OracleParams.ahead
KINDS = ("approach", "clear")
#: The per-frame ground truth the labels read.
TRUTH = ("threat_ttc", "threat_bearing")


@dataclass(frozen=True)
class FrameLabel:
    """What the objective needs to know of a robot clip: its kind, and per frame whether
    it is a window frame and whether it is a clear frame (booleans, one per frame)."""

    kind: str  # one of KINDS
    window: np.ndarray
    clear: np.ndarray


def frame_label(kind: str, ttc: np.ndarray, bearing: np.ndarray,
                window_s: tuple[float, float] | None = None, horizon: float | None = None
                ) -> FrameLabel:
    """A clip's label from its threat's time to collision (s) and bearing (rad) per frame,
    with the window's times to collision and the horizon (the benchmark's detection track
    gives its protocol's; None: this module's `TTC_LO`, `TTC_HI` and `HORIZON`)."""
    low, high = (TTC_LO, TTC_HI) if window_s is None else window_s
    ttc = np.asarray(ttc, np.float64)
    ahead = np.abs(np.degrees(np.asarray(bearing, np.float64))) <= AHEAD
    window = ahead & (ttc >= low) & (ttc <= high)
    # a clear clip's threat is passed, not met, whatever its time to collision says
    return FrameLabel(kind, window & (kind == "approach"),
                      ttc > (HORIZON if horizon is None else horizon))


def hits(labels: Sequence[FrameLabel], potentials: Sequence[np.ndarray],
         thresholds: np.ndarray) -> np.ndarray:
    """(clips, thresholds) booleans: whether each clip is a hit at each threshold."""
    out = np.empty((len(labels), len(thresholds)), bool)
    for i, (label, p) in enumerate(zip(labels, potentials, strict=True)):
        first = first_crossings(p, thresholds)  # len(p): never
        if label.kind == "clear":
            out[i] = first >= len(p)
        else:
            out[i] = np.append(label.window, False)[first]
    return out


def frame_counts(labels: Sequence[FrameLabel], potentials: Sequence[np.ndarray],
                 thresholds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At each threshold, the window frames alarmed and the clear frames silent, over all
    clips: every threshold from one sort of each clip's potentials."""
    alarmed = np.zeros(len(thresholds), np.int64)
    silent = np.zeros(len(thresholds), np.int64)
    for label, p in zip(labels, potentials, strict=True):
        p = np.asarray(p, np.float64)
        window, clear = np.sort(p[label.window]), np.sort(p[label.clear])
        alarmed += len(window) - np.searchsorted(window, thresholds, side="right")
        silent += np.searchsorted(clear, thresholds, side="right")
    return alarmed, silent


class _Robot(Objective):
    def identity(self) -> dict[str, Any]:
        # another alarm rule is another objective
        return {"window": [TTC_LO, TTC_HI], "horizon": HORIZON, "ahead": AHEAD,
                "alarm": dataclasses.asdict(self.alarm)}

    def label(self, record: Mapping[str, Any], truth: Mapping[str, np.ndarray]
              ) -> FrameLabel:
        return frame_label(record["kind"], truth["threat_ttc"], truth["threat_bearing"])

    def scores(self, labels: Sequence[FrameLabel], potentials: Sequence[np.ndarray],
               thresholds: np.ndarray) -> dict[str, Any]:
        # each frame's alarm level under the rule: above a threshold exactly where it alarms
        levels = [self.alarm.series(p) for p in potentials]
        alarmed, silent = frame_counts(labels, levels, thresholds)
        return {"hits": pack_hits(hits(labels, levels, thresholds)),
                "window": alarmed.tolist(), "clear": silent.tolist(),
                "window_frames": int(sum(label.window.sum() for label in labels)),
                "clear_frames": int(sum(label.clear.sum() for label in labels))}

    def value(self, kinds: np.ndarray, scores: Mapping[str, Any], at: slice
              ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        parts = kind_rates(kinds, unpack_hits(scores["hits"], len(kinds))[:, at], KINDS)
        shares = [np.array(scores[k][at]) / scores[f"{k}_frames"] for k in ("window", "clear")
                  if scores[f"{k}_frames"]]
        if shares:
            parts["frames"] = np.mean(shares, axis=0)
        return np.mean(list(parts.values()), axis=0), parts


#: The robot task's objective.
ROBOT = _Robot(
    text=__doc__.strip(),
    parts={"approach": "approach clips hit", "clear": "clear clips silent",
           "frames": "frame balanced accuracy"},
    titles={"objective": "objective\n(mean of the parts present)",
            "approach": "approach clips:\nfirst alarm in the manoeuvre's window",
            "clear": "clear clips:\nno alarm",
            "frames": "frames: balanced accuracy\n(window alarmed, clear silent)"},
    fields={"hits": [list], "window": [int], "clear": [int], "window_frames": int,
            "clear_frames": int},
    truth=TRUTH)
#: The robot task's objective under the video presets' alarm rule
#: (`lgmd_sim.calibration.objective.VIDEO`'s), issue 43: whether that rule helps the robot.
ROBOT_FRAMES = dataclasses.replace(
    ROBOT, alarm=VIDEO.alarm,
    text=f"{ROBOT.text}\n\nHere an alarm is {VIDEO.alarm} the threshold (the video presets' "
         "rule), not a frame above it.")
