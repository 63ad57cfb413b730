"""What every stimulus shares: the clip and its ground truth, the grey scale and the
backgrounds it is drawn on, the checks of its arguments, and the clip seen by a shaking
camera."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from lgmd_sim.core.params import checked, int_at_least, positive
from lgmd_sim.signals import noise

#: Texture amplitude around the background level (fraction of full scale).
TEXTURE_AMPLITUDE = 0.1
#: A uniform grey, or a seeded smooth random texture about it.
BACKGROUNDS = ("uniform", "texture")


@dataclass(frozen=True, eq=False)
class Stimulus:
    """A synthetic clip and its ground truth.

    :param frames: (T, H, W) uint8 grey frames.
    :param fps: frames per second.
    :param collision_frame: the first frame at which the object reaches the eye; None when
        it never does.
    :param name: a short description, e.g. "approaching dark square".
    :param angular_size: (T,) the object's angular size in radians per frame (pi at
        collision); None for stimuli without an object (grating, flicker).
    """

    frames: np.ndarray
    fps: float
    collision_frame: int | None
    name: str
    angular_size: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frames)


def fraction(value: Any) -> str | None:
    """A `lgmd_sim.core.params` check: a number in (0, 1] (a contrast, a modulation depth)."""
    return None if positive(value) is None and value <= 1 else "must be a number in (0, 1]"


def positive_float(name: str, value: Any) -> float:
    """``value``, checked to be a finite number > 0, as a float."""
    return float(checked(name, value, positive))


def count(name: str, value: Any, lo: int) -> int:
    """``value``, checked to be an integer >= ``lo``."""
    return int(checked(name, value, int_at_least(lo)))


def frame_shape(shape: Sequence[int]) -> tuple[int, int]:
    """``shape``, checked to be (height, width), both at least 2."""
    if len(shape) != 2:
        raise ValueError(f"shape must be (height, width), got {shape!r}")
    return count("shape height", shape[0], 2), count("shape width", shape[1], 2)


def draw_background(shape: tuple[int, int], level: float, kind: str, seed: int
                    ) -> np.ndarray:
    """A uniform grey ``level``, or a seeded texture about it (float, clipped to 0..1).

    :param kind: one of `BACKGROUNDS` (checked by the caller).
    :param seed: seed of the texture (checked by the caller).
    """
    bg = np.full(shape, level, np.float32)
    if kind == "texture":
        bg += TEXTURE_AMPLITUDE * _texture(shape, np.random.default_rng(seed))
    return np.clip(bg, 0.0, 1.0)


def _texture(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Smooth random texture, zero mean, in [-1, 1]: coarse blobs plus finer grain."""
    h, w = shape
    out = np.zeros(shape, np.float32)
    for cell, weight in ((16, 1.0), (4, 0.5)):
        grid = rng.random((h // cell + 2, w // cell + 2)).astype(np.float32)
        out += weight * cv2.resize(grid, (w, h), interpolation=cv2.INTER_CUBIC)
    out -= out.mean()
    return out / max(float(np.abs(out).max()), 1e-6)


def to_uint8(img: np.ndarray) -> np.ndarray:
    """Grey levels on the 0..1 scale as uint8, rounded and clipped."""
    return np.clip(np.rint(img * 255.0), 0, 255).astype(np.uint8)


def jittered(stimulus: Stimulus, level: float, seed: int = 0) -> Stimulus:
    """The same stimulus seen by a shaking camera: `lgmd_sim.signals.noise`'s ``shake:level``.

    Every frame gets an independent random rotation about the image centre, shift and
    brightness gain (their sizes per level: ``noise.SHAKE_*``); borders are replicated, so
    no black edges flash. Level 0 returns the frames unchanged. Frame t gets the shake
    that ``noise.apply(frame, [Noise("shake", level)], seed, t)`` draws: a clip and a
    frame stream corrupted with ``shake:level`` and the same seed shake alike.

    :param stimulus: the clip to shake.
    :param level: jitter level, in the range `noise.KINDS` gives ``shake``.
    :param seed: seed of the jitter, >= 0.
    :return: the shaken clip, its name marked with the level.
    """
    shake = [noise.Noise("shake", level)]
    frames = np.stack(list(noise.corrupt(stimulus.frames, shake, count("seed", seed, 0))))
    return dataclasses.replace(stimulus, frames=frames, name=f"{stimulus.name}, jitter {level:g}")
