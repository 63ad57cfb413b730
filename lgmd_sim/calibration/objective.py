"""The declared objective of the calibration: every clip is a hit or a miss.

Clips fall in three kinds, and each kind weighs the same in the objective:

- **jitter**: a shaking camera approaching an obstacle until it collides. A hit when the
  first alarm falls in the last 15% (``LATE``) of the approach (frames 0 to the
  collision) and at or before the collision; earlier is a false alarm of the shake, later
  or never a miss.
- **stationary**: a steady camera (jitter 0) and a collision. A hit when the model alarms
  at or before the collision.
- **near miss**: no collision. A hit (a correct rejection) when the model never alarms.

objective = mean of the three kinds' hit rates, in [0, 1]. Never crossing the threshold
is a miss on a collision clip: the mean SI rewarded exactly that silence (docs/models.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["KINDS", "LATE", "ClipLabel", "first_crossings", "hits", "objective"]

KINDS = ("jitter", "stationary", "near_miss")
#: A jitter clip's first alarm must fall in this last fraction of its approach.
LATE = 0.15


@dataclass(frozen=True)
class ClipLabel:
    """What the objective needs to know of a clip."""

    kind: str  # one of KINDS
    frames: int
    collision_frame: int | None

    @property
    def window(self) -> tuple[int, int]:
        """First and last frame of a hit's first alarm (inclusive); (frames, -1) for none."""
        if self.collision_frame is None:
            return self.frames, -1
        if self.kind == "jitter":
            start = self.collision_frame - int(np.floor(LATE * self.collision_frame))
            return start, self.collision_frame
        return 0, self.collision_frame


def first_crossings(potential: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """For each threshold, the first frame whose potential exceeds it (len(potential) for
    none): every threshold from one pass, since the running maximum is sorted."""
    running = np.maximum.accumulate(np.asarray(potential, np.float64))
    return np.searchsorted(running, thresholds, side="right")


def hits(labels: Sequence[ClipLabel], potentials: Sequence[np.ndarray],
         thresholds: np.ndarray) -> np.ndarray:
    """(clips, thresholds) booleans: whether each clip is a hit at each threshold."""
    out = np.empty((len(labels), len(thresholds)), bool)
    for i, (label, p) in enumerate(zip(labels, potentials, strict=True)):
        first = first_crossings(p, thresholds)
        if label.collision_frame is None:
            out[i] = first >= label.frames  # never alarms
        else:
            lo, hi = label.window
            out[i] = (first >= lo) & (first <= hi)
    return out


def objective(labels: Sequence[ClipLabel], hit: np.ndarray) -> tuple[np.ndarray, dict]:
    """The objective at each threshold (columns of `hit`), and each kind's hit rate."""
    kinds = np.array([label.kind for label in labels])
    rates = {k: hit[kinds == k].mean(axis=0) for k in KINDS if (kinds == k).any()}
    return np.mean(list(rates.values()), axis=0), rates
