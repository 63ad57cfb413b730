"""Evaluation metrics: the paper's ISI, MpSI and SI (Eq. 21-23) and the event metrics.

Frame indices are 0-based throughout (as in ``lgmd-sim detect``'s CSV and
``--collision-frame``), except where the paper's SI counts frames (see
`sensitivity_index`).

>>> from lgmd_sim.signals import metrics
>>> metrics.isi(frames)                       # Eq. 21: mean SSIM of consecutive frames
>>> metrics.mpsi(potentials)                  # Eq. 22: max / mean
>>> metrics.sensitivity_index(potentials)     # Eq. 23, with the never-crossed case flagged
>>> ev = metrics.evaluate_clip(potentials, collision_frame=120, fps=30)
>>> metrics.score([ev, ...])                  # the group's score, 0..100
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from lgmd_sim.core.frames import to_grey
from lgmd_sim.core.params import checked, non_negative, optional, positive, seed

__all__ = [
    "DEFAULT_THRESHOLD",
    "PAPER_ALARM",
    "AlarmRule",
    "EventResult",
    "Sensitivity",
    "alarm_onsets",
    "evaluate_clip",
    "first_alarm",
    "isi",
    "mpsi",
    "roc_auc",
    "roc_curve",
    "score",
    "sensitivity_index",
    "ssim",
    "ssim_series",
    "wilson_interval",
]

#: Membrane-potential threshold of the paper (Sec. 4.1.3).
DEFAULT_THRESHOLD = 0.8

# SSIM as Wang, Bovik, Sheikh & Simoncelli (2004): an 11 x 11 Gaussian window with
# sigma 1.5, K1 = 0.01, K2 = 0.03, averaged over the positions where the window fits.
_SSIM_SIGMA = 1.5
_SSIM_WINDOW = 11
_SSIM_K1, _SSIM_K2 = 0.01, 0.03


# --- frame similarity ---------------------------------------------------------------------


def _grey(frame: np.ndarray, what: str) -> tuple[np.ndarray, float]:
    """A frame as float32 grey and its data range: 255 for uint8, 1 for float (0..1)."""
    a = to_grey(frame, what)
    if a.dtype == np.uint8:
        return a.astype(np.float32), 255.0
    if not np.issubdtype(a.dtype, np.floating):
        raise ValueError(f"{what}: frames must be uint8 or float, got {a.dtype}")
    if not np.isfinite(a).all():
        raise ValueError(f"{what}: frame contains NaN or infinite values")
    return a.astype(np.float32), 1.0


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Structural similarity of two frames (Wang et al. 2004), in [-1, 1].

    Grey or RGB colour (converted to grey, BT.601), uint8 (range 255) or float (range 1).
    Local statistics use a Gaussian window (sigma 1.5, 11 x 11); the map is averaged over
    the positions where the whole window fits (the whole frame when it is smaller).
    Computed in float32 (within 1e-6 of a float64 evaluation).
    """
    x, range_a = _grey(a, "ssim: first frame")
    y, range_b = _grey(b, "ssim: second frame")
    if x.shape != y.shape:
        raise ValueError(f"ssim: frame sizes differ: {x.shape} and {y.shape}")
    if range_a != range_b:
        raise ValueError("ssim: frames must both be uint8 or both float")
    c1, c2 = (_SSIM_K1 * range_a) ** 2, (_SSIM_K2 * range_a) ** 2
    # float32 is twice as fast; centring the values keeps E[x^2] - E[x]^2 accurate in it
    centre = np.float32(range_a / 2)
    x, y = x - centre, y - centre

    def blur(z: np.ndarray) -> np.ndarray:
        return cv2.GaussianBlur(z, (_SSIM_WINDOW, _SSIM_WINDOW), _SSIM_SIGMA,
                                borderType=cv2.BORDER_REFLECT)

    mu_x, mu_y = blur(x), blur(y)
    var_x = blur(x * x) - mu_x * mu_x
    var_y = blur(y * y) - mu_y * mu_y
    cov = blur(x * y) - mu_x * mu_y
    mu_x, mu_y = mu_x + centre, mu_y + centre
    s = ((2 * mu_x * mu_y + c1) * (2 * cov + c2)) / (
        (mu_x * mu_x + mu_y * mu_y + c1) * (var_x + var_y + c2)
    )
    r = _SSIM_WINDOW // 2
    if min(s.shape) > 2 * r:
        s = s[r:-r, r:-r]
    return float(s.mean(dtype=np.float64))


def ssim_series(frames: Iterable[np.ndarray]) -> np.ndarray:
    """SSIM of each frame with the previous one: (T,) floats, NaN for frame 0."""
    out = [np.nan]
    prev = None
    for frame in frames:
        if prev is not None:
            out.append(ssim(prev, frame))
        prev = frame
    if prev is None:
        raise ValueError("ssim_series: no frames")
    return np.asarray(out)


def isi(frames: Iterable[np.ndarray]) -> float:
    """Interframe Similarity Index (Eq. 21): the mean SSIM of consecutive frames."""
    series = ssim_series(frames)
    if len(series) < 2:
        raise ValueError("isi: needs at least two frames")
    return float(series[1:].mean())


# --- membrane-potential indices -----------------------------------------------------------


def _series(values: Sequence[float] | np.ndarray, what: str) -> np.ndarray:
    a = np.asarray(values)
    if a.ndim != 1 or a.size == 0:
        raise ValueError(f"{what}: expected a non-empty 1-D series, got shape {a.shape}")
    if a.dtype != np.bool_:
        a = a.astype(np.float64)
        if not np.isfinite(a).all():
            raise ValueError(f"{what}: series contains NaN or infinite values")
    return a


def mpsi(potentials: Sequence[float] | np.ndarray) -> float:
    """Membrane Potential Stability Index (Eq. 22): max(Mp) / mean(Mp)."""
    mp = _series(potentials, "mpsi").astype(np.float64)
    mean = float(mp.mean())
    if mean <= 0:
        raise ValueError(f"mpsi: the mean potential must be > 0, got {mean:g}")
    return float(mp.max()) / mean


@dataclass(frozen=True)
class AlarmRule:
    """When a potential series alarms: above the threshold in `frames` consecutive
    frames (1: every frame above it, the paper's Eq. 23), and with `rising` also never
    falling within them (a looming object's response climbs to the collision; a
    motion's onset transient or a shake's surge falls back). A model's rule comes from
    its ``alarm_frames`` and ``alarm_rising``."""

    frames: int = 1
    rising: bool = False

    def __str__(self) -> str:
        """The rule in words, to end with "the threshold": "4 rising frames above"."""
        if self.frames <= 1:
            return "a frame above"
        return f"{self.frames} {'rising ' if self.rising else ''}frames running above"

    def levels(self, windows: np.ndarray) -> np.ndarray:
        """The alarm level of each window of the last `frames` potentials (..., frames),
        oldest first: their least, -inf where the rule cannot fire (a window not yet
        full, i.e. holding -inf, or one that falls with `rising`); a window alarms
        exactly where its level is above the threshold."""
        if self.frames <= 1:  # the potential itself, as cheaply as a model step needs
            return windows[..., -1]
        level = windows.min(axis=-1)
        if self.rising:
            with np.errstate(invalid="ignore"):  # -inf - -inf in a window not yet full
                climbs = (np.diff(windows, axis=-1) >= 0).all(axis=-1)
            level = np.where(climbs, level, -np.inf)
        return level

    def series(self, potentials: Sequence[float] | np.ndarray) -> np.ndarray:
        """Each frame's alarm level (`levels` of the window ending there)."""
        mp = np.asarray(potentials, np.float64)
        if self.frames <= 1:
            return mp
        out = np.full(mp.shape, -np.inf)
        if len(mp) >= self.frames:
            out[self.frames - 1:] = self.levels(
                np.lib.stride_tricks.sliding_window_view(mp, self.frames))
        return out


#: The paper's alarm (Eq. 23): every frame whose potential is above the threshold.
PAPER_ALARM = AlarmRule()


def first_alarm(
    values: Sequence[float] | np.ndarray, threshold: float = DEFAULT_THRESHOLD,
    rule: AlarmRule = PAPER_ALARM,
) -> int | None:
    """The first frame (0-based) with an alarm, or None.

    Args:
        values: alarm flags (bool), or membrane potentials compared with ``threshold``
            (an alarm is a potential strictly above it, as the models flag it).
        threshold: the potential threshold.
        rule: with potentials, when they alarm (a model's `AlarmRule`).
    """
    a = _series(values, "first_alarm")
    if a.dtype != np.bool_:
        a = rule.series(a)
    hits = a if a.dtype == np.bool_ else a > threshold
    idx = np.flatnonzero(hits)
    return int(idx[0]) if idx.size else None


def alarm_onsets(alarms: Sequence[bool] | np.ndarray) -> np.ndarray:
    """The frames (0-based) where an alarm turns on: alarmed, and not in the frame before
    (how alarms are counted: a run of alarmed frames is one alarm)."""
    a = np.asarray(alarms, bool)
    return np.flatnonzero(a & ~np.r_[False, a[:-1]])


@dataclass(frozen=True)
class Sensitivity:
    """The Sensitivity Index (Eq. 23) of one series.

    Attributes:
        si: frames up to and including the first alarm, over the number of frames, in
            (0, 1]; 1.0 when the potential never crosses (see ``crossed``).
        crossed: whether the potential ever exceeded the threshold.
        first_alarm: the first frame (0-based) above the threshold, or None.
        n_frames: the number of frames.
    """

    si: float
    crossed: bool
    first_alarm: int | None
    n_frames: int


def sensitivity_index(
    potentials: Sequence[float] | np.ndarray, threshold: float = DEFAULT_THRESHOLD,
    rule: AlarmRule = PAPER_ALARM,
) -> Sensitivity:
    """Sensitivity Index (Eq. 23): SI = F_n / N_f; smaller means an earlier alarm.

    F_n counts frames from 1 (the paper's numbering), so an alarm on the last frame gives
    1. The paper leaves the never-crossed case undefined: it is reported as si = 1.0 with
    crossed = False, never silently (docs/experiments/models-log.md). `rule`: when the
    potentials alarm (a model's `AlarmRule`).
    """
    mp = _series(potentials, "sensitivity_index")
    first = first_alarm(mp, threshold, rule)
    n = len(mp)
    if first is None:
        return Sensitivity(1.0, False, None, n)
    return Sensitivity((first + 1) / n, True, first, n)


# --- events: hit, miss, false alarm -------------------------------------------------------

Outcome = Literal["hit", "miss", "false_alarm", "correct_rejection"]


@dataclass(frozen=True)
class EventResult:
    """One clip judged against its label.

    Attributes:
        outcome: for a collision clip "hit" (first alarm within the window before the
            collision) or "miss" (no alarm, too early or too late); for a clip without
            collision "false_alarm" (any alarm) or "correct_rejection".
        first_alarm: the first alarm frame, or None.
        collision_frame: the labelled collision frame, None for a non-collision clip.
        window_frames: the tolerance window, frames before the collision.
        lead_frames: collision_frame - first_alarm (positive: before the collision), or
            None without an alarm or a collision.
        lead_s: lead_frames in seconds.
    """

    outcome: Outcome
    first_alarm: int | None
    collision_frame: int | None
    window_frames: int
    lead_frames: int | None
    lead_s: float | None

    @property
    def collision(self) -> bool:
        return self.collision_frame is not None


def evaluate_clip(
    values: Sequence[float] | np.ndarray,
    collision_frame: int | None,
    fps: float,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    window_s: float = 1.0,
) -> EventResult:
    """Judge a clip's alarms against its labelled collision frame.

    A collision clip is a hit when its first alarm falls in the window of ``window_s``
    seconds (round(window_s * fps) frames) before the collision, collision frame
    included; otherwise a miss. A clip without collision (``collision_frame=None``) with
    any alarm is a false alarm. This is the evaluation of the group's published code
    (fuqinbing/LGMD-Plus-and-GAs-Open-Source, LGMDEvolution.cs).

    Args:
        values: membrane potentials or alarm flags, one per frame.
        collision_frame: 0-based labelled collision frame, or None.
        fps: frames per second of the clip.
        threshold: potential threshold (unused for alarm flags).
        window_s: tolerance window before the collision, seconds.
    """
    checked("fps", fps, positive)
    checked("window_s", window_s, non_negative)
    checked("collision_frame", collision_frame, optional(seed))
    first = first_alarm(values, threshold)
    window = round(window_s * fps)
    if collision_frame is None:
        outcome: Outcome = "correct_rejection" if first is None else "false_alarm"
        return EventResult(outcome, first, None, window, None, None)
    collision_frame = int(collision_frame)
    if first is None:
        return EventResult("miss", None, collision_frame, window, None, None)
    lead = collision_frame - first
    outcome = "hit" if 0 <= lead <= window else "miss"
    return EventResult(outcome, first, collision_frame, window, lead, lead / fps)


def score(results: Iterable[EventResult]) -> float:
    """The group's score over a set of clips: (1 - (3 Fcol + Fnon) / (3 Ncol + Nnon)) x 100.

    Fcol counts missed collision clips out of Ncol, Fnon false alarms out of Nnon clips
    without collision; a miss weighs three times a false alarm. 100 is perfect.
    """
    results = list(results)
    if not results:
        raise ValueError("score: no clips")
    n_col = sum(r.collision for r in results)
    f_col = sum(r.outcome == "miss" for r in results)
    f_non = sum(r.outcome == "false_alarm" for r in results)
    n_non = len(results) - n_col
    return (1 - (3 * f_col + f_non) / (3 * n_col + n_non)) * 100


# --- rates --------------------------------------------------------------------------------


def wilson_interval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a rate ``successes / n`` (95% for z = 1.96).

    Unlike the normal approximation it stays inside [0, 1] and is sensible at 0 and n,
    where benchmark rates (collisions of an oracle, of a robot driving blind) often are.
    """
    if n <= 0 or not 0 <= successes <= n:
        raise ValueError(f"wilson_interval: need 0 <= successes <= n and n > 0, got "
                         f"{successes} of {n}")
    p = successes / n
    denominator = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    return float(max(0.0, centre - half)), float(min(1.0, centre + half))


# --- detection curves ---------------------------------------------------------------------


def _scores_labels(scores: Sequence[float] | np.ndarray, labels: Sequence[bool] | np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    s = np.asarray(scores, np.float64).ravel()
    y = np.asarray(labels, bool).ravel()
    if s.shape != y.shape:
        raise ValueError(f"scores and labels differ in length: {s.size} and {y.size}")
    if not np.isfinite(s).all():
        raise ValueError("scores must be finite")
    return s, y


def roc_curve(scores: Sequence[float] | np.ndarray, labels: Sequence[bool] | np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """False and true positive rates of ``score >= t`` for every threshold t among the
    scores (highest first), from (0, 0) to (1, 1); and the thresholds."""
    s, y = _scores_labels(scores, labels)
    order = np.argsort(-s, kind="stable")
    s, y = s[order], y[order]
    last = np.r_[np.flatnonzero(np.diff(s)), s.size - 1]  # the last index of each value
    tp, fp = np.cumsum(y)[last], np.cumsum(~y)[last]
    n_pos, n_neg = max(int(y.sum()), 1), max(int((~y).sum()), 1)
    return (np.r_[0.0, fp / n_neg], np.r_[0.0, tp / n_pos], np.r_[np.inf, s[last]])


def roc_auc(scores: Sequence[float] | np.ndarray, labels: Sequence[bool] | np.ndarray
            ) -> float | None:
    """Area under the ROC curve: the chance that a positive frame scores above a negative
    one (ties count half). None when either class is empty."""
    s, y = _scores_labels(scores, labels)
    n_pos, n_neg = int(y.sum()), int((~y).sum())
    if n_pos == 0 or n_neg == 0:
        return None
    order = np.argsort(s, kind="stable")
    ranks = np.empty(s.size)
    sorted_s = s[order]
    starts = np.r_[0, np.flatnonzero(np.diff(sorted_s)) + 1]
    ends = np.r_[starts[1:], s.size]
    ranks[order] = np.repeat((starts + ends + 1) / 2, ends - starts)  # average ranks of ties
    return float((ranks[y].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))
