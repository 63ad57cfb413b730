"""Sanity baselines for the leaderboard: what an LGMD must beat to have added anything.

Every serious leaderboard has a floor made of trivial entries; here two looming "detectors"
named by their specs wherever a model name goes (they are not built-ins):

- ``lgmd_sim.benchmark.baselines:FrameDifference``: the simplest looming cue, the mean
  absolute frame difference of the view's centre over its own running mean. No lateral
  inhibition, no excitation spreading over time, no selectivity for expansion: whatever an
  LGMD does beyond "more change ahead than lately" shows as its margin over this row;
- ``lgmd_sim.benchmark.baselines:RandomAlarm``: alarms at random, at the rate the
  LGMD-driven reactive controller raises them, blind to the frames: a detector that does
  no better than it avoids only by stopping and turning often enough.

Both keep the `LGMDModel` contract (``lgmd_sim.models.check_model`` passes) and report a
potential in [0.5, 1], so the inherited alarm threshold (0.8) and alarm rule apply.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from lgmd_sim.core.params import in_range, int_at_least, param
from lgmd_sim.models import LGMDModel, ModelParams, SearchRange, StateMap

__all__ = ["FrameDifference", "FrameDifferenceParams", "RandomAlarm", "RandomAlarmParams"]

_OURS = "ours: the simplest looming cue, the leaderboard's floor"


@dataclass(frozen=True)
class FrameDifferenceParams(ModelParams):
    """Parameters of `FrameDifference`."""

    window: float = param(
        0.5, f"{_OURS}: the middle half of the rows and columns, where an obstacle ahead is",
        check=in_range(0.05, 1.0),
        doc="share of the rows and of the columns, about the centre, whose change counts")
    tau: float = param(
        15.0, f"{_OURS}: 0.5 s at 30 fps: the mean lags an approach's growing change, and "
        "follows steady driving's; on StationaryApproach (jitter 0) its first alarm came "
        "0.9 s before the collision at 64 x 64, 0.6 s at 120 x 160 (8 frames: 0.7, 0.4 s)",
        check=in_range(1.0, 1000.0),
        doc="time constant of the change's running mean (an exponential moving average), "
            "in frames")
    slope: float = param(
        1.4, f"{_OURS}: ln 4 / 1.4 = 0.99, so the threshold 0.8 is crossed when the "
        "change is about twice its running mean",
        check=in_range(0.01, 100.0),
        doc="potential = 1 / (1 + exp(-slope * excess)), excess = change / (running mean + "
            "floor) - 1, rectified")
    floor: float = param(
        0.2, f"{_OURS}: so that a still scene (no change, no mean) rests; small beside a "
        "near obstacle's change (1 to 4 grey levels a pixel on StationaryApproach, 64 x 64), "
        "where 1 grey level kept it from alarming at all",
        check=in_range(0.01, 255.0),
        doc="grey levels added to the running mean before the ratio")


class FrameDifference(LGMDModel):
    """The simplest looming cue: the mean absolute frame difference of the view's centre,
    over its own running mean.

    Per stream and frame: change = mean |L(t) - L(t-1)| over the central ``window`` (grey
    levels, 0 on a stream's first frame); excess = change / (mean + ``floor``) - 1,
    rectified, mean the exponential moving average of the change up to the frame before
    (time constant ``tau``); potential = 1 / (1 + exp(-``slope`` * excess)). A still scene or
    a steady change rests at 0.5; a change growing faster than its mean follows, as a
    looming object's does, saturates towards 1. The stream's first change seeds its mean,
    so a stream that starts in motion starts at rest. Layer P: |L(t) - L(t-1)| over the
    whole frame.
    """

    name: ClassVar[str] = "frame_difference"
    Params: ClassVar[type[ModelParams]] = FrameDifferenceParams
    layer_names: ClassVar[tuple[str, ...]] = ("P",)
    presets: ClassVar[dict[str, dict[str, Any]]] = {"default": {}}
    search_space: ClassVar[dict[str, SearchRange]] = {
        "slope": SearchRange(0.1, 20.0), "tau": SearchRange(2.0, 60.0)}

    params: FrameDifferenceParams

    def allocate(self, n: int, height: int, width: int) -> None:
        self._prev = np.zeros((n, height, width), np.float32)
        self._seen = np.zeros(n, np.int8)  # frames seen, up to 2: none, the first, more
        self._mean = np.zeros(n)
        rows, cols = (max(1, round(s * self.params.window)) for s in (height, width))
        top, left = (height - rows) // 2, (width - cols) // 2
        self._centre = np.s_[:, top:top + rows, left:left + cols]

    def reset_streams(self, idx: np.ndarray) -> None:
        self._seen[idx] = 0
        self._mean[idx] = 0.0

    def state_maps(self) -> list[StateMap]:
        return [StateMap("_prev", "frame")]

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        p = self.params
        frame = grey.astype(np.float32)  # a copy: grey is read-only and shared
        first = self._seen == 0
        self._prev[first] = frame[first]
        change = np.abs(frame - self._prev)
        self._prev = frame
        if layers is not None:
            layers["P"][...] = change
        level = change[self._centre].mean(axis=(1, 2), dtype=np.float64)
        mean = np.where(self._seen == 1, level, self._mean)
        excess = np.maximum(level / (mean + p.floor) - 1.0, 0.0)
        self._mean = mean + (level - mean) / p.tau
        self._seen = np.minimum(self._seen + 1, 2).astype(np.int8)
        return 1.0 / (1.0 + np.exp(-p.slope * excess))


@dataclass(frozen=True)
class RandomAlarmParams(ModelParams):
    """Parameters of `RandomAlarm`."""

    rate_per_min: float = param(
        6.0, "ours: matched to the LGMD-driven reactive controller at jitter 1 (docs/"
        "experiments/results-log.md, robot section): the mean false alarms a minute of "
        "lgmd1/robot-image and feedback/robot-image, the robot presets that beat Straight, on "
        "RoughTerrainObstacles (10.6, 7.5) and ArenaRoam (4.2, 2.0)",
        check=in_range(0.0, 60_000.0),
        doc="alarms a minute (each frame alarms with probability rate_per_min / 60 / fps, "
            "with alarm_frames 1)")
    fps: float = param(
        30.0, "the environments' frame rate (lgmd_sim.world.params, fps)",
        check=in_range(1.0, 1000.0), doc="frames a second of the streams")
    seed: int = param(
        0, "ours", check=int_at_least(0),
        doc="seed of the draws; each stream's generator is seeded by it and the stream's "
            "first frame")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.rate_per_min > 60.0 * self.fps:
            raise ValueError(f"{type(self).__name__}: parameter rate_per_min="
                             f"{self.rate_per_min!r} exceeds one alarm a frame at fps="
                             f"{self.fps!r} ({60.0 * self.fps:g} a minute)")


class RandomAlarm(LGMDModel):
    """Alarms at random at a given rate, blind to the frames.

    Each frame, each stream draws two uniform numbers. The first, u, is mapped to the
    potential so that it exceeds the threshold exactly when u < q = ``rate_per_min`` / 60 /
    ``fps``: into (threshold, 1] then, into [0.5, threshold] otherwise. The second picks
    the half of the view the layer "side" puts the threat in (1 there, 0 elsewhere), so
    that the reactive controller (side="halves") turns away at random too. Deterministic:
    a stream's generator is seeded by ``seed`` and the bytes of its first frame (the one
    thing a stream has of its own: a batch must give what each stream gives alone, so not
    its index), anew on `reset`; the frames after the first are ignored. Without state
    maps: it runs without front ends only.
    """

    name: ClassVar[str] = "random_alarm"
    Params: ClassVar[type[ModelParams]] = RandomAlarmParams
    layer_names: ClassVar[tuple[str, ...]] = ("side",)
    presets: ClassVar[dict[str, dict[str, Any]]] = {"default": {}}

    params: RandomAlarmParams

    def allocate(self, n: int, height: int, width: int) -> None:
        self._rngs: list[np.random.Generator | None] = [None] * n

    def reset_streams(self, idx: np.ndarray) -> None:
        for i in idx:
            self._rngs[i] = None  # seeded by the stream's next frame

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        p = self.params
        for i, rng in enumerate(self._rngs):
            if rng is None:
                digest = hashlib.blake2b(grey[i].tobytes(), digest_size=8).digest()
                self._rngs[i] = np.random.default_rng([p.seed, int.from_bytes(digest)])
        u, left = np.array([rng.random(2) for rng in self._rngs]).T
        if layers is not None:
            half = grey.shape[2] // 2
            side = layers["side"]
            side[...] = 0.0
            side[left < 0.5, :, :half] = 1.0
            side[left >= 0.5, :, side.shape[2] - half:] = 1.0
        # falling from 1 at u = 0 through the threshold at u = q to 0.5 at u = 1: above the
        # threshold exactly when u < q (at u = q = 0, interp takes the threshold: no alarm)
        q = p.rate_per_min / 60.0 / p.fps
        return np.interp(u, [0.0, q, 1.0], [1.0, p.threshold, 0.5])
