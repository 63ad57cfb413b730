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
is a miss on a collision clip: the mean SI rewarded exactly that silence
(docs/experiments/models-log.md).
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.core.runs import Fields
from lgmd_sim.signals.metrics import PAPER_ALARM, AlarmRule

__all__ = ["KINDS", "LATE", "THRESHOLDS", "VIDEO", "WALKER", "ClipLabel", "Objective",
           "first_crossings", "hits", "kind_rates", "objective", "pack_hits", "unpack_hits"]

#: The thresholds every candidate is scored at (potentials lie in [0.5, 1)).
THRESHOLDS = np.round(np.arange(0.52, 0.995, 0.005), 4)
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
         thresholds: np.ndarray, rule: AlarmRule = PAPER_ALARM) -> np.ndarray:
    """(clips, thresholds) booleans: whether each clip is a hit at each threshold, its
    potentials alarming by `rule`."""
    out = np.empty((len(labels), len(thresholds)), bool)
    for i, (label, p) in enumerate(zip(labels, potentials, strict=True)):
        first = first_crossings(rule.series(p), thresholds)
        if label.collision_frame is None:
            out[i] = first >= label.frames  # never alarms
        else:
            lo, hi = label.window
            out[i] = (first >= lo) & (first <= hi)
    return out


def kind_rates(kinds: np.ndarray, hit: np.ndarray, names: Sequence[str]
               ) -> dict[str, np.ndarray]:
    """Each kind's hit rate at each threshold (columns of `hit`), of the kinds present."""
    return {k: hit[kinds == k].mean(axis=0) for k in names if (kinds == k).any()}


def objective(labels: Sequence[ClipLabel], hit: np.ndarray) -> tuple[np.ndarray, dict]:
    """The objective at each threshold (columns of `hit`), and each kind's hit rate."""
    rates = kind_rates(np.array([label.kind for label in labels]), hit, KINDS)
    return np.mean(list(rates.values()), axis=0), rates


def pack_hits(hit: np.ndarray) -> list:
    """(clips, thresholds) booleans as a candidate's record keeps them: bits, a row a clip."""
    return np.packbits(hit, axis=1).tolist()


def unpack_hits(bits: list, clips: int) -> np.ndarray:
    """The (clips, `THRESHOLDS`) booleans of `pack_hits`."""
    return np.unpackbits(np.array(bits, np.uint8), axis=1,
                         count=len(THRESHOLDS))[:clips].astype(bool)


@dataclass(frozen=True)
class Objective(ABC):
    """A calibration task's declared objective, as the search and the choice use it: a
    label per clip from its record and ground truth, one candidate's scores on a set of
    clips at every threshold (JSON, from one run), and the objective those give.

    Attributes:
        text: the objective as declared (saved with the presets it chose).
        parts: what the objective averages, each with its summary column's heading.
        titles: the figure's panel title of the objective and of each part.
        fields: what a set's scores hold (`lgmd_sim.core.runs.Fields`), checked on resuming.
        truth: the per-frame ground truth (``info`` names) its labels read.
    """

    text: str
    parts: Mapping[str, str]
    titles: Mapping[str, str]
    fields: Fields
    truth: tuple[str, ...] = ()
    #: When a candidate's potentials alarm (its presets' ``alarm_frames`` and
    #: ``alarm_rising``).
    alarm: AlarmRule = PAPER_ALARM

    @abstractmethod
    def identity(self) -> dict[str, Any]:
        """What identifies the objective in a run's configuration (its constants)."""

    @abstractmethod
    def label(self, record: Mapping[str, Any], truth: Mapping[str, np.ndarray]) -> Any:
        """What the objective needs to know of a clip: its record and its `truth`."""

    @abstractmethod
    def scores(self, labels: Sequence[Any], potentials: Sequence[np.ndarray],
               thresholds: np.ndarray) -> Any:
        """One candidate's scores on a set of clips at every threshold (JSON-ready)."""

    @abstractmethod
    def value(self, kinds: np.ndarray, scores: Any, at: slice
              ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The objective and each part at the thresholds `at` of `THRESHOLDS`, from
        `scores` of clips of these kinds."""


class _Walker(Objective):
    def identity(self) -> dict[str, Any]:
        # a longer alarm is another objective
        return {"late": LATE, "alarm": dataclasses.asdict(self.alarm)}

    def label(self, record: Mapping[str, Any], truth: Mapping[str, np.ndarray]) -> ClipLabel:
        return ClipLabel(record["kind"], record["frames"], record["collision_frame"])

    def scores(self, labels: Sequence[ClipLabel], potentials: Sequence[np.ndarray],
               thresholds: np.ndarray) -> list:
        return pack_hits(hits(labels, potentials, thresholds, self.alarm))

    def value(self, kinds: np.ndarray, scores: list, at: slice
              ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        rates = kind_rates(kinds, unpack_hits(scores, len(kinds))[:, at], tuple(self.parts))
        return np.mean(list(rates.values()), axis=0), rates


class _Balanced(_Walker):
    """The walker's hits, combined so that neither silence nor firing on everything pays:
    the geometric mean of the collision kinds' mean hit rate and the silence kinds'."""

    collisions = ("jitter", "stationary")

    def value(self, kinds: np.ndarray, scores: list, at: slice
              ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        _, rates = super().value(kinds, scores, at)
        halves = [[v for k, v in rates.items() if (k in self.collisions) == side]
                  for side in (True, False)]
        if not all(halves):
            raise ValueError("the video objective needs clips of a collision kind and of a "
                             f"silence kind; these are of {', '.join(rates)} only")
        alarm, silence = (np.mean(h, axis=0) for h in halves)
        return np.sqrt(alarm * silence), rates


#: The walker task's objective (this module's; the robot's: `lgmd_sim.calibration.robot`).
WALKER = _Walker(
    text=__doc__.strip(),
    parts={"jitter": "jitter hits", "stationary": "stationary hits",
           "near_miss": "near misses rejected"},
    titles={"objective": "objective\n(mean of the three kinds)",
            "jitter": "jitter clips:\nfirst alarm late and before the collision",
            "stationary": "stationary clips:\nan alarm before the collision",
            "near_miss": "near misses:\nno alarm"},
    fields=[list])

#: The video task's objective: the walker's hits, a fourth kind of clip scored alike, and
#: the kinds combined so that a silent model scores 0.
VIDEO = _Balanced(
    text="""The declared objective of the video calibration: the walker's, for footage from a
camera nobody calibrated, and silence on what does not loom.

Clips fall in four kinds, two that should alarm and two that should not; every clip has
a real camera's noise on top of its shake (white shake, motion blur, auto-exposure,
sensor noise and compression, `lgmd_sim.calibration.clips.VIDEO_LOOKS`), and the scenes'
cameras have fields of view from 40 to 90 degrees while the front end assumes 60.
Besides the search and held-out seeds, a transfer set of the held-out seeds in other
looks (a worse camera, low sun, shade and flicker, stimuli on plain grounds) says how much
of the score survives a domain the calibration never saw:

- **jitter**: a shaking camera approaching an obstacle, or a synthetic object looming at
  it, until it collides. A hit when the first alarm falls in the last 15% of the approach
  and at or before the collision.
- **stationary**: a steady camera and a collision. A hit when the model alarms at or
  before the collision.
- **near miss**: an object passing by. A hit when the model never alarms.
- **non-looming**: synthetic stimuli that move without looming: an object receding,
  crossing the view or turning, a drifting grating, the whole field dimming and
  lightening, steady or shaken. A hit when the model never alarms.

An alarm is the potential above the threshold in 4 consecutive frames (the Colias
robot's LGMD; the published LGMD1 code asks 5), never falling within them: a looming
object's response climbs to the collision, while a shake's one-frame surges and the
transient at the onset of a motion fall back. The presets keep the rule (alarm_frames,
alarm_rising).

alarms = mean of the jitter and stationary hit rates; silences = mean of the near miss
and non-looming hit rates; objective = sqrt(alarms x silences), in [0, 1]. A model that
never alarms scores 0, as does one that alarms on everything: with the plain mean of the
four kinds, silence alone scored 0.5, and the first video calibration chose silent
settings for two of its six detectors (the first version of docs/results/calibration-video
in the project's history). The kinds' hit rates do not depend on how they are combined,
so a run resumed after a change of combination chooses again from the same candidates.""",
    parts={"jitter": "jitter hits", "stationary": "stationary hits",
           "near_miss": "near misses rejected", "non_looming": "non-looming rejected"},
    titles={"objective": "objective: geometric mean of\nalarms and silences",
            "jitter": "jitter clips:\nfirst alarm late and before the collision",
            "stationary": "stationary clips:\nan alarm before the collision",
            "near_miss": "near misses:\nno alarm",
            "non_looming": "receding, crossing, turning,\ngratings, flicker: no alarm"},
    fields=[list], alarm=AlarmRule(4, rising=True))
