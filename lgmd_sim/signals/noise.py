"""Seeded frame corruptions: the paper's noisy streams (its dataset d), extra shake and a
real camera's exposure, sensor noise, motion blur and compression.

- ``gaussian:V``: additive Gaussian noise of variance V on the [0, 1] grey scale, clipped
  (the paper uses V = 0.001 to 0.009, as MATLAB's ``imnoise(I, 'gaussian', 0, V)``);
- ``saltpepper:D``: a fraction D of pixels set to black or white with equal odds (the
  paper's densities 0.001 to 0.009, as ``imnoise(I, 'salt & pepper', D)``);
- ``shake:L``: an extra image-space shake at level L, drawn afresh for every frame: a
  rotation about the centre, a translation on each axis and a brightness gain, their
  standard deviations L times `SHAKE_ROTATION_SD` (degrees), `SHAKE_SHIFT_SD` (pixels)
  and `SHAKE_GAIN_SD` (log gain); borders replicated. The synthetic stimuli shake with it
  too (`lgmd_sim.signals.stimuli.jittered`);
- ``exposure:L``: a real camera's auto-exposure, a global brightness gain that drifts
  smoothly: its log is a sum of `EXPOSURE_WAVES` sines of random frequency (in
  `EXPOSURE_CYCLES` per frame) and phase, drawn once per stream, with a standard deviation
  of L times `EXPOSURE_SD`;
- ``sensor:L``: a camera sensor's noise, signal-dependent (Poisson-Gaussian, Foi et al.
  2008): on the [0, 1] scale, x + sqrt(a x + b) N(0, 1) with a = L^2 `SENSOR_SHOT` (the
  photon shot noise) and b = (L `SENSOR_READ`)^2 (the read noise), clipped;
- ``blur:L``: motion blur at the shutter time: the image smeared along a line of random
  direction, its length drawn per frame from a half-normal of standard deviation L times
  `BLUR_SD` pixels (the camera's shake during an exposure; image space, so it costs a
  filter, not the sub-frame renders a world's blur would);
- ``jpeg:Q``: compression artefacts, each frame encoded and decoded as a JPEG of quality
  Q (1 to 100; OpenCV's libjpeg, 4:2:0 chroma for colour frames).

>>> from lgmd_sim.signals import noise
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
    "BLUR_SD",
    "EXPOSURE_CYCLES",
    "EXPOSURE_SD",
    "EXPOSURE_WAVES",
    "KINDS",
    "SENSOR_READ",
    "SENSOR_SHOT",
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
    "exposure": (0.0, 10.0),   # level: a multiple of EXPOSURE_SD
    "sensor": (0.0, 10.0),     # level: a multiple of the SENSOR_* noise
    "blur": (0.0, 10.0),       # level: a multiple of BLUR_SD
    "jpeg": (1.0, 100.0),      # JPEG quality: lower is coarser
}

#: Shake at level 1, standard deviations per frame: rotation about the image centre
#: (degrees), translation on each image axis (pixels) and the log of the brightness gain.
#: Round values, not fitted to a camera (the calibrated jitter scale is the world's,
#: `lgmd_sim.world.params`). The shift is in pixels, not a fraction of the width: a level
#: moves a small frame further across its view than a large one.
SHAKE_ROTATION_SD = 1.0
SHAKE_SHIFT_SD = 2.0
SHAKE_GAIN_SD = 0.05

#: Auto-exposure at level 1: the standard deviation of the log gain (about 10% either
#: way), the sines it sums and their frequency range in cycles per frame (0.33 to 3 Hz at
#: 30 frames/s: an exposure loop settles in a fraction of a second to a few seconds).
#: Round values, not fitted to a camera. At level 1 the gain changes by a few percent a
#: frame, at most 15% (three sines at the top frequency in phase: 3 x 2 pi f x amplitude).
EXPOSURE_SD = 0.1
EXPOSURE_WAVES = 3
EXPOSURE_CYCLES = (1 / 90, 1 / 10)

#: Motion blur at level 1: the standard deviation of the smear's length (pixels, whatever
#: the frame's size, like the shake's shift). A round value: a hand-held camera at 1/60 s
#: smears a few pixels.
BLUR_SD = 3.0

#: Sensor noise at level 1, on the [0, 1] scale: the shot-noise variance per unit of
#: signal (a standard deviation of 0.014 at mid-grey) and the read noise's standard
#: deviation. Round values of a small camera in daylight, not fitted to one (Foi et al.
#: 2008, IEEE TIP 17(10), fit such pairs to raw data).
SENSOR_SHOT = 4e-4
SENSOR_READ = 4e-3


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

    def apply(self, frame: np.ndarray, rng: np.random.Generator, *, seed: int,
              index: int) -> np.ndarray:
        """This corruption of one uint8 frame, frame `index` of the stream seeded `seed`,
        drawn from `rng` (the frame's own generator; `rng_for`)."""
        if self.level == 0:
            return frame
        if self.kind == "exposure":
            return _gain(frame, self.level * EXPOSURE_SD * _drift(seed, index))
        if self.kind == "sensor":
            x = frame / 255.0
            sd = self.level * np.sqrt(SENSOR_SHOT * x + SENSOR_READ ** 2)
            return np.rint(np.clip(x + sd * rng.standard_normal(frame.shape), 0.0, 1.0)
                           * 255.0).astype(np.uint8)
        if self.kind == "jpeg":
            return _jpeg(frame, round(self.level))
        if self.kind == "blur":
            length = abs(rng.normal(0.0, self.level * BLUR_SD))
            return _smear(frame, length, rng.uniform(0.0, np.pi))
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
        return _gain(moved, log_gain)


def _gain(frame: np.ndarray, log_gain: float) -> np.ndarray:
    return np.clip(np.rint(frame * np.exp(log_gain)), 0, 255).astype(np.uint8)


def _drift(seed: int, index: int) -> float:
    """The auto-exposure's log gain at frame `index` of stream `seed`, in units of its
    standard deviation: the stream's sines (drawn from the seed alone, so that any frame's
    gain is made alone) at that frame. One camera, one exposure loop: two ``exposure``
    entries in a list drift together (``exposure:1,exposure:1`` is ``exposure:2``)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(b"exposure")]))
    cycles = rng.uniform(*EXPOSURE_CYCLES, EXPOSURE_WAVES)
    phases = rng.uniform(0.0, 2 * np.pi, EXPOSURE_WAVES)
    # a sine of random phase has variance 1/2: the sum of n, n/2
    return float(np.sqrt(2 / EXPOSURE_WAVES)
                 * np.sin(2 * np.pi * cycles * index + phases).sum())


def _smear(frame: np.ndarray, length: float, angle: float) -> np.ndarray:
    """`frame` averaged along a centred line of `length` pixels at `angle` (radians)."""
    if length < 1.0:
        return frame
    size = 2 * int(np.ceil(length / 2)) + 1
    kernel = np.zeros((size, size), np.float32)
    centre, half = (size - 1) / 2, length / 2
    dx, dy = half * np.cos(angle), half * np.sin(angle)
    # sub-pixel line ends: cv2.line's shift, 8 fractional bits
    ends = [(round((centre + sx * dx) * 256), round((centre + sx * dy) * 256))
            for sx in (-1, 1)]
    cv2.line(kernel, ends[0], ends[1], 1.0, 1, cv2.LINE_AA, shift=8)
    kernel /= kernel.sum()
    out = cv2.filter2D(frame, -1, kernel, borderType=cv2.BORDER_REPLICATE)
    return out.reshape(frame.shape)


def _jpeg(frame: np.ndarray, quality: int) -> np.ndarray:
    """`frame` encoded and decoded as a JPEG of `quality` (RGB: OpenCV's order is BGR, and
    the encoder's colour transform depends on it)."""
    colour = frame.ndim == 3 and frame.shape[2] == 3
    ok, data = cv2.imencode(".jpg", frame[..., ::-1] if colour else frame,
                            [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError(f"noise jpeg: OpenCV could not encode a {frame.shape} frame")
    out = cv2.imdecode(data, cv2.IMREAD_COLOR if colour else cv2.IMREAD_GRAYSCALE)
    return (out[..., ::-1] if colour else out).reshape(frame.shape)


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
        frame = n.apply(frame, rng, seed=seed, index=index)
    return frame


def corrupt(frames: Iterable[np.ndarray], noises: Sequence[Noise], seed: int
            ) -> Iterator[np.ndarray]:
    """`apply` to each frame of a stream, in order."""
    for index, frame in enumerate(frames):
        yield apply(frame, noises, seed, index)
