"""Seeded frame corruptions: the paper's noisy streams (its dataset d) and extra shake.

- ``gaussian:V``: additive Gaussian noise of variance V on the [0, 1] grey scale, clipped
  (the paper uses V = 0.001 to 0.009, as MATLAB's ``imnoise(I, 'gaussian', 0, V)``);
- ``saltpepper:D``: a fraction D of pixels set to black or white with equal odds (the
  paper's densities 0.001 to 0.009, as ``imnoise(I, 'salt & pepper', D)``);
- ``shake:L``: an extra image-space shake at level L, drawn afresh for every frame: a
  rotation about the centre, a translation on each axis and a brightness gain, their
  standard deviations L times `SHAKE_ROTATION_SD` (degrees), `SHAKE_SHIFT_SD` (pixels)
  and `SHAKE_GAIN_SD` (log gain); borders replicated. The synthetic stimuli shake with it
  too (`lgmd_sim.stimuli.jittered`).

>>> from lgmd_sim import noise
>>> noises = noise.parse("gaussian:0.005,saltpepper:0.005")
>>> noisy = list(noise.corrupt(frames, noises, seed=0))   # same seed, same noise

Frames are uint8, grey (H, W) or RGB (H, W, 3); the result has the same shape and type.
The noise of a stream depends only on the seed, the noise list and the frame's index.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = [
    "KINDS",
    "SHAKE_GAIN_SD",
    "SHAKE_ROTATION_SD",
    "SHAKE_SHIFT_SD",
    "Noise",
    "apply",
    "corrupt",
    "parse",
    "rng_for",
]

#: Each kind and the range of its level.
KINDS: dict[str, tuple[float, float]] = {
    "gaussian": (0.0, 1.0),    # variance on the [0, 1] scale
    "saltpepper": (0.0, 1.0),  # fraction of pixels
    "shake": (0.0, 10.0),      # level: a multiple of the SHAKE_* standard deviations
}

#: Shake at level 1, standard deviations per frame: rotation about the image centre
#: (degrees), translation on each image axis (pixels) and the log of the brightness gain.
#: Round values, not fitted to a camera (the calibrated jitter scale is the world's,
#: `lgmd_sim.world.params`). The shift is in pixels, not a fraction of the width: a level
#: moves a small frame further across its view than a large one.
SHAKE_ROTATION_SD = 1.0
SHAKE_SHIFT_SD = 2.0
SHAKE_GAIN_SD = 0.05


@dataclass(frozen=True)
class Noise:
    """One corruption: its kind (see `KINDS`) and level."""

    kind: str
    level: float

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown noise {self.kind!r}; known: {', '.join(KINDS)}")
        lo, hi = KINDS[self.kind]
        if not (isinstance(self.level, int | float) and lo <= self.level <= hi):
            raise ValueError(f"noise {self.kind}: level must be a number in [{lo:g}, {hi:g}], "
                             f"got {self.level!r}")

    def __str__(self) -> str:
        return f"{self.kind}:{self.level:g}"

    def apply(self, frame: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """This corruption of one uint8 frame, drawn from `rng`."""
        if self.level == 0:
            return frame
        if self.kind == "gaussian":
            noisy = frame / 255.0 + rng.normal(0.0, np.sqrt(self.level), frame.shape)
            return np.rint(np.clip(noisy, 0.0, 1.0) * 255.0).astype(np.uint8)
        if self.kind == "saltpepper":
            out = frame.copy()
            u = rng.random(frame.shape[:2])
            out[u < self.level / 2] = 0
            out[(u >= self.level / 2) & (u < self.level)] = 255
            return out
        h, w = frame.shape[:2]
        angle, dx, dy, log_gain = rng.normal(0.0, [SHAKE_ROTATION_SD, SHAKE_SHIFT_SD,
                                                   SHAKE_SHIFT_SD, SHAKE_GAIN_SD]) * self.level
        m = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), angle, 1.0)
        m[:, 2] += (dx, dy)
        moved = cv2.warpAffine(frame, m, (w, h), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_REPLICATE)
        return np.clip(np.rint(moved * np.exp(log_gain)), 0, 255).astype(np.uint8)


def parse(spec: str | Sequence[Noise] | None) -> list[Noise]:
    """Noises from "kind:level,kind:level" (or a list of `Noise`; None or "" for none)."""
    if spec is None or spec == "":
        return []
    if not isinstance(spec, str):
        return list(spec)
    noises = []
    for item in spec.split(","):
        kind, sep, level = item.strip().partition(":")
        try:
            value = float(level)
        except ValueError:
            value = None
        if not sep or value is None:
            raise ValueError(f"bad noise {item.strip()!r}: write kind:level, e.g. "
                             f"gaussian:0.005 (kinds: {', '.join(KINDS)})")
        noises.append(Noise(kind, value))
    return noises


def rng_for(noises: Sequence[Noise], seed: int, index: int) -> np.random.Generator:
    """The generator of frame `index` of a stream: from the seed, the noise list and the
    index only, so any frame's noise can be made alone (a dataset's noisy view)."""
    tag = zlib.crc32(",".join(map(str, noises)).encode())
    return np.random.default_rng(np.random.SeedSequence([int(seed), tag, int(index)]))


def apply(frame: np.ndarray, noises: Sequence[Noise], seed: int, index: int) -> np.ndarray:
    """Every noise, in order, on frame `index` of the stream seeded `seed`."""
    frame = np.asarray(frame)
    if frame.dtype != np.uint8:
        raise ValueError(f"noise: frames must be uint8, got {frame.dtype}")
    if not noises:
        return frame
    rng = rng_for(noises, seed, index)
    for n in noises:
        frame = n.apply(frame, rng)
    return frame


def corrupt(frames: Iterable[np.ndarray], noises: Sequence[Noise], seed: int
            ) -> Iterator[np.ndarray]:
    """`apply` to each frame of a stream, in order."""
    for index, frame in enumerate(frames):
        yield apply(frame, noises, seed, index)
