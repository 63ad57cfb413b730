"""Synthetic stimuli: the classic LGMD characterisation set, seeded, as uint8 grey frames.

Objects (a dark or light square or disc) live in a small pinhole-camera world: an object
of half-size ``half_size`` metres at distance ``d`` on the optical axis has the angular
size ``2 atan(half_size / d)`` and is drawn with exact area coverage at its edges, so a
looming edge moves smoothly by fractions of a pixel. Every moving stimulus starts with
``still_frames`` identical frames so that a model begins at rest.

>>> from lgmd_sim import stimuli
>>> s = stimuli.approaching(polarity="dark")          # looming to collision
>>> s.frames.shape, s.collision_frame                 # ((51, 120, 160), 50)
>>> shaken = stimuli.jittered(s, level=1.0, seed=3)   # the same, seen by a shaking camera
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from lgmd_sim.params import Check, int_at_least, one_of, positive

__all__ = [
    "Stimulus",
    "approaching",
    "flicker",
    "grating",
    "jittered",
    "receding",
    "static",
    "translating",
]

#: Texture amplitude around the background level (fraction of full scale).
TEXTURE_AMPLITUDE = 0.1
#: Jitter at level 1: shift s.d. as a fraction of the frame width, rotation s.d. in
#: degrees, and s.d. of the log brightness gain. A level scales all three.
JITTER_SHIFT_SD = 0.015
JITTER_ROTATION_SD = 1.0
JITTER_GAIN_SD = 0.05


@dataclass(frozen=True, eq=False)
class Stimulus:
    """A synthetic clip and its ground truth.

    Attributes:
        frames: (T, H, W) uint8 grey frames.
        fps: frames per second.
        collision_frame: the first frame at which the object reaches the eye; None when
            it never does.
        name: a short description, e.g. "approaching dark square".
        angular_size: (T,) the object's angular size in radians per frame (pi at
            collision); None for stimuli without an object (grating, flicker).
    """

    frames: np.ndarray
    fps: float
    collision_frame: int | None
    name: str
    angular_size: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frames)


# --- argument checks ----------------------------------------------------------------------


def _require(name: str, value: Any, check: Check) -> Any:
    """`value` if the project's parameter `check` accepts it, else a ValueError naming it."""
    error = check(value)
    if error:
        raise ValueError(f"{name} {error}, got {value!r}")
    return value


def _check_positive(name: str, value: float) -> float:
    return float(_require(name, value, positive))


def _check_count(name: str, value: int, lo: int) -> int:
    return int(_require(name, value, int_at_least(lo)))


def _check_choice(name: str, value: str, choices: Sequence[str]) -> str:
    return _require(name, value, one_of(*choices))


def _check_fraction(name: str, value: float) -> float:
    if _check_positive(name, value) > 1:
        raise ValueError(f"{name} must be in (0, 1], got {value!r}")
    return float(value)


def _check_shape(shape: Sequence[int]) -> tuple[int, int]:
    if len(shape) != 2:
        raise ValueError(f"shape must be (height, width), got {shape!r}")
    return _check_count("shape height", shape[0], 2), _check_count("shape width", shape[1], 2)


# --- rendering ----------------------------------------------------------------------------


def _texture(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Smooth random texture, zero mean, in [-1, 1]: coarse blobs plus finer grain."""
    h, w = shape
    out = np.zeros(shape, np.float32)
    for cell, weight in ((16, 1.0), (4, 0.5)):
        grid = rng.random((h // cell + 2, w // cell + 2)).astype(np.float32)
        out += weight * cv2.resize(grid, (w, h), interpolation=cv2.INTER_CUBIC)
    out -= out.mean()
    return out / max(float(np.abs(out).max()), 1e-6)


def _scene(
    shape: tuple[int, int], polarity: str, contrast: float, background: str, seed: int
) -> tuple[np.ndarray, float]:
    """The background image (float, 0..1) and the object's grey level.

    The object and the background sit symmetrically about mid-grey, ``contrast`` apart:
    a dark object on a light background, or a light one on a dark background.
    """
    _check_choice("polarity", polarity, ("dark", "light"))
    contrast = _check_fraction("contrast", contrast)
    sign = 1.0 if polarity == "dark" else -1.0
    return _background(shape, 0.5 + sign * contrast / 2, background, seed), (
        0.5 - sign * contrast / 2
    )


def _background(shape: tuple[int, int], level: float, background: str, seed: int) -> np.ndarray:
    """A uniform grey ``level``, or a seeded texture about it (float, clipped to 0..1)."""
    _check_choice("background", background, ("uniform", "texture"))
    rng = _rng(seed)
    bg = np.full(shape, level, np.float32)
    if background == "texture":
        bg += TEXTURE_AMPLITUDE * _texture(shape, rng)
    return np.clip(bg, 0.0, 1.0)


def _rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(_check_count("seed", seed, 0))


def _coverage(
    shape: tuple[int, int], form: str, cx: float, cy: float, half: float
) -> np.ndarray:
    """Fraction of each pixel covered by a square (half-side) or disc (radius) ``half``.

    Pixel (i, j) covers [j - 0.5, j + 0.5] x [i - 0.5, i + 0.5]; ``half`` may be inf.
    """
    h, w = shape
    x = np.arange(w, dtype=np.float64)
    y = np.arange(h, dtype=np.float64)
    if form == "square":  # exact: the overlap of two intervals, per axis
        cov_x = np.clip(np.minimum(x + 0.5, cx + half) - np.maximum(x - 0.5, cx - half), 0, 1)
        cov_y = np.clip(np.minimum(y + 0.5, cy + half) - np.maximum(y - 0.5, cy - half), 0, 1)
        return np.outer(cov_y, cov_x)
    # disc: coverage from the signed distance to the rim (exact for straight edges)
    dist = np.hypot(x[None, :] - cx, y[:, None] - cy)
    cov = np.clip(half + 0.5 - dist, 0.0, 1.0)
    if half < 1.0 and cov.sum() > 0:  # a sub-pixel disc: keep its area right
        cov *= math.pi * half * half / cov.sum()
    return cov


def _to_uint8(img: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(img * 255.0), 0, 255).astype(np.uint8)


def _focal_px(width: int, fov: float) -> float:
    """Focal length in pixels for a horizontal field of view ``fov`` (degrees)."""
    fov = _check_positive("fov", fov)
    if fov >= 180:
        raise ValueError(f"fov must be below 180 degrees, got {fov!r}")
    return (width / 2) / math.tan(math.radians(fov) / 2)


def _render_object(
    name: str,
    shape: Sequence[int],
    *,
    distances: np.ndarray,
    centres_x: np.ndarray | None,
    polarity: str,
    form: str,
    half_size: float,
    fps: float,
    fov: float,
    contrast: float,
    background: str,
    seed: int,
    collision_frame: int | None,
) -> Stimulus:
    """Draw the object at the given distance (and image column of its centre) per frame."""
    shape = _check_shape(shape)
    _check_choice("form", form, ("square", "disc"))
    half_size = _check_positive("half_size", half_size)
    fps = _check_positive("fps", fps)
    focal = _focal_px(shape[1], fov)
    bg, level = _scene(shape, polarity, contrast, background, seed)
    cy, cx0 = (shape[0] - 1) / 2, (shape[1] - 1) / 2
    frames = np.empty((len(distances), *shape), np.uint8)
    for t, d in enumerate(distances):
        half_px = focal * half_size / d if d > 0 else math.inf
        cx = cx0 if centres_x is None else centres_x[t]
        cov = _coverage(shape, form, cx, cy, half_px)
        frames[t] = _to_uint8(bg + (level - bg) * cov)
    angular = np.where(
        distances > 0, 2 * np.arctan(half_size / np.maximum(distances, 1e-12)), math.pi
    )
    return Stimulus(frames, fps, collision_frame, name, angular)


def _still(n: int, value: float) -> np.ndarray:
    return np.full(_check_count("still_frames", n, 0), value, np.float64)


# --- the stimulus set ---------------------------------------------------------------------


def approaching(
    shape: Sequence[int] = (120, 160),
    *,
    polarity: str = "dark",
    form: str = "square",
    half_size: float = 0.1,
    start_distance: float = 3.0,
    speed: float = 2.0,
    still_frames: int = 5,
    fps: float = 30.0,
    fov: float = 60.0,
    contrast: float = 0.8,
    background: str = "uniform",
    seed: int = 0,
) -> Stimulus:
    """An object looming at constant speed straight at the eye, up to collision.

    With the defaults (a 0.2 m square from 3 m at 2 m/s, half-size over speed 50 ms, a
    60 degree view) the object grows from 9 pixels across to fill the 160 x 120 view in
    the last few frames; the clip ends on the collision frame (the first with distance
    <= 0, the object covering the whole view).

    Args:
        shape: (height, width) of the frames.
        polarity: "dark" (a dark object on a light background) or "light" (the reverse).
        form: "square" or "disc".
        half_size: the object's half-side (square) or radius (disc), metres.
        start_distance: distance when the motion starts, metres.
        speed: approach speed, metres per second.
        still_frames: identical frames before the motion starts.
        fps: frames per second.
        fov: horizontal field of view, degrees.
        contrast: grey-level difference between object and background, in (0, 1].
        background: "uniform" or "texture" (a seeded smooth random texture).
        seed: seed of the texture.
    """
    start_distance = _check_positive("start_distance", start_distance)
    speed = _check_positive("speed", speed)
    n_motion = math.ceil(start_distance * _check_positive("fps", fps) / speed - 1e-9)
    motion = start_distance - speed * np.arange(n_motion + 1) / fps
    distances = np.concatenate([_still(still_frames, start_distance), motion])
    return _render_object(
        f"approaching {polarity} {form}", shape, distances=distances, centres_x=None,
        polarity=polarity, form=form, half_size=half_size, fps=fps, fov=fov,
        contrast=contrast, background=background, seed=seed,
        collision_frame=still_frames + n_motion,
    )


def receding(
    shape: Sequence[int] = (120, 160),
    *,
    polarity: str = "dark",
    form: str = "square",
    half_size: float = 0.1,
    near_distance: float = 0.5,
    end_distance: float = 3.0,
    speed: float = 2.0,
    still_frames: int = 5,
    fps: float = 30.0,
    fov: float = 60.0,
    contrast: float = 0.8,
    background: str = "uniform",
    seed: int = 0,
) -> Stimulus:
    """An object moving straight away at constant speed: the time reverse of an approach.

    It is the reverse of an approach from ``end_distance`` to ``near_distance``, which
    stops short of collision: a recession starting from an object that fills the whole
    view would begin with a step change of the image. With the defaults the object starts
    55 pixels across (about half the view's height). Arguments as in `approaching`.
    """
    near_distance = _check_positive("near_distance", near_distance)
    end_distance = _check_positive("end_distance", end_distance)
    if end_distance <= near_distance:
        raise ValueError(f"end_distance ({end_distance}) must exceed near_distance "
                         f"({near_distance})")
    speed = _check_positive("speed", speed)
    fps = _check_positive("fps", fps)
    n_motion = math.ceil((end_distance - near_distance) * fps / speed - 1e-9)
    motion = np.minimum(near_distance + speed * np.arange(n_motion + 1) / fps, end_distance)
    distances = np.concatenate([_still(still_frames, near_distance), motion])
    return _render_object(
        f"receding {polarity} {form}", shape, distances=distances, centres_x=None,
        polarity=polarity, form=form, half_size=half_size, fps=fps, fov=fov,
        contrast=contrast, background=background, seed=seed, collision_frame=None,
    )


def translating(
    shape: Sequence[int] = (120, 160),
    *,
    polarity: str = "dark",
    form: str = "square",
    half_size: float = 0.1,
    distance: float = 0.5,
    speed: float = 1.0,
    still_frames: int = 5,
    fps: float = 30.0,
    fov: float = 60.0,
    contrast: float = 0.8,
    background: str = "uniform",
    seed: int = 0,
) -> Stimulus:
    """An object of constant size crossing the view from left to right at constant speed.

    It enters from just outside the left border and leaves fully past the right one;
    the still frames show the background alone. With the defaults the object is 55
    pixels across (as a receding one starts) and moves 9.2 pixels per frame, between
    the edge speeds of the default approach at 0.5 m (3.7) and 0.25 m (14.8) from the eye.

    Args:
        distance: the object's distance, metres (sets its image size).
        speed: lateral speed, metres per second.
        Others as in `approaching`.
    """
    shape = _check_shape(shape)
    distance = _check_positive("distance", distance)
    speed = _check_positive("speed", speed)
    fps = _check_positive("fps", fps)
    focal = _focal_px(shape[1], fov)
    half_px = focal * _check_positive("half_size", half_size) / distance
    step_px = focal * speed / distance / fps
    n_motion = math.ceil((shape[1] + 2 * half_px) / step_px)
    start = -0.5 - half_px  # right edge on the left border of the first column
    centres = np.concatenate([np.full(_check_count("still_frames", still_frames, 0), -1e9),
                              start + step_px * np.arange(n_motion + 1)])
    return _render_object(
        f"translating {polarity} {form}", shape, distances=np.full(len(centres), distance),
        centres_x=centres, polarity=polarity, form=form, half_size=half_size, fps=fps,
        fov=fov, contrast=contrast, background=background, seed=seed, collision_frame=None,
    )


def static(
    shape: Sequence[int] = (120, 160),
    *,
    n_frames: int = 30,
    polarity: str = "dark",
    form: str = "square",
    half_size: float = 0.1,
    distance: float = 1.0,
    fps: float = 30.0,
    fov: float = 60.0,
    contrast: float = 0.8,
    background: str = "texture",
    seed: int = 0,
) -> Stimulus:
    """A still scene: the object at rest before a textured background, every frame identical.

    Args:
        n_frames: number of frames.
        distance: the object's distance, metres.
        Others as in `approaching`.
    """
    n_frames = _check_count("n_frames", n_frames, 1)
    distance = _check_positive("distance", distance)
    return _render_object(
        f"static {polarity} {form}", shape, distances=np.full(n_frames, distance),
        centres_x=None, polarity=polarity, form=form, half_size=half_size, fps=fps, fov=fov,
        contrast=contrast, background=background, seed=seed, collision_frame=None,
    )


def _wave(phase: np.ndarray, waveform: str) -> np.ndarray:
    """A sine or square wave of ``phase`` (radians), in [-1, 1]."""
    return np.sin(phase) if waveform == "sine" else np.sign(np.sin(phase))


def grating(
    shape: Sequence[int] = (120, 160),
    *,
    period: float = 32.0,
    speed: float = 120.0,
    orientation: float = 0.0,
    waveform: str = "sine",
    contrast: float = 0.8,
    n_frames: int = 60,
    still_frames: int = 5,
    fps: float = 30.0,
) -> Stimulus:
    """A full-field grating drifting at constant speed.

    Square waves are rendered at 4 x 4 supersampling, so their edges are anti-aliased.

    Args:
        period: spatial period, pixels.
        speed: drift speed across the bars, pixels per second.
        orientation: direction of drift, degrees (0: vertical bars drifting rightwards).
        waveform: "sine" or "square".
        contrast: peak-to-peak amplitude about mid-grey, in (0, 1].
        n_frames: frames of motion (after the still frames).
    """
    h, w = _check_shape(shape)
    period = _check_positive("period", period)
    speed = _check_positive("speed", speed)
    fps = _check_positive("fps", fps)
    if not math.isfinite(orientation):
        raise ValueError(f"orientation must be a finite number, got {orientation!r}")
    _check_choice("waveform", waveform, ("sine", "square"))
    contrast = _check_fraction("contrast", contrast)
    n_frames = _check_count("n_frames", n_frames, 1)
    ss = 1 if waveform == "sine" else 4
    offs = (np.arange(ss) + 0.5) / ss - 0.5  # sub-pixel sample positions
    ys = (np.arange(h)[:, None] + offs[None, :]).reshape(-1)
    xs = (np.arange(w)[:, None] + offs[None, :]).reshape(-1)
    theta = math.radians(orientation)
    along = xs[None, :] * math.cos(theta) + ys[:, None] * math.sin(theta)
    shifts = np.concatenate([np.zeros(_check_count("still_frames", still_frames, 0)),
                             speed * np.arange(n_frames) / fps])
    frames = np.empty((len(shifts), h, w), np.uint8)
    for t, s in enumerate(shifts):
        img = 0.5 + contrast / 2 * _wave(2 * math.pi * (along - s) / period, waveform)
        if ss > 1:
            img = img.reshape(h, ss, w, ss).mean(axis=(1, 3))
        frames[t] = _to_uint8(img)
    return Stimulus(frames, fps, None, f"{waveform} grating", None)


def flicker(
    shape: Sequence[int] = (120, 160),
    *,
    frequency: float = 2.0,
    depth: float = 0.5,
    waveform: str = "sine",
    background: str = "uniform",
    n_frames: int = 60,
    still_frames: int = 5,
    fps: float = 30.0,
    seed: int = 0,
) -> Stimulus:
    """Whole-field brightness modulation: the scene times ``1 + depth * wave(2 pi f t)``.

    Args:
        frequency: modulation frequency, Hz.
        depth: modulation depth, in (0, 1].
        waveform: "sine" or "square".
        background: "uniform" (mid-grey) or "texture" (mid-grey, seeded texture).
        n_frames: frames of modulation (after the still frames).
    """
    shape = _check_shape(shape)
    frequency = _check_positive("frequency", frequency)
    depth = _check_fraction("depth", depth)
    _check_choice("waveform", waveform, ("sine", "square"))
    fps = _check_positive("fps", fps)
    n_frames = _check_count("n_frames", n_frames, 1)
    bg = _background(shape, 0.5, background, seed)
    t = np.arange(n_frames) / fps
    gains = np.concatenate([np.ones(_check_count("still_frames", still_frames, 0)),
                            1 + depth * _wave(2 * math.pi * frequency * t, waveform)])
    frames = _to_uint8(gains[:, None, None] * bg[None])
    return Stimulus(frames, fps, None, f"{waveform} flicker {frequency:g} Hz", None)


def jittered(stimulus: Stimulus, level: float, seed: int = 0) -> Stimulus:
    """The same stimulus seen by a shaking camera.

    Every frame gets an independent random shift (sub-pixel), rotation about the image
    centre and brightness gain, with standard deviations ``level`` times
    `JITTER_SHIFT_SD` x width pixels, `JITTER_ROTATION_SD` degrees and `JITTER_GAIN_SD`
    (log gain). Borders are reflected, so no black edges flash. Level 0 returns the frames
    unchanged.

    Args:
        stimulus: the clip to shake.
        level: jitter level, >= 0.
        seed: seed of the jitter.
    """
    if isinstance(level, bool) or not isinstance(level, int | float | np.integer | np.floating) \
            or not math.isfinite(level) or level < 0:
        raise ValueError(f"level must be a finite number >= 0, got {level!r}")
    rng = _rng(seed)
    name = f"{stimulus.name}, jitter {level:g}"
    if level == 0:
        return dataclasses.replace(stimulus, frames=stimulus.frames.copy(), name=name)
    n, h, w = stimulus.frames.shape
    shifts = rng.normal(0.0, level * JITTER_SHIFT_SD * w, (n, 2))
    angles = rng.normal(0.0, level * JITTER_ROTATION_SD, n)
    gains = np.exp(rng.normal(0.0, level * JITTER_GAIN_SD, n))
    centre = ((w - 1) / 2, (h - 1) / 2)
    out = np.empty_like(stimulus.frames)
    for t, frame in enumerate(stimulus.frames):
        m = cv2.getRotationMatrix2D(centre, float(angles[t]), 1.0)
        m[:, 2] += shifts[t]
        warped = cv2.warpAffine(frame.astype(np.float32), m, (w, h), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_REFLECT)
        out[t] = np.clip(np.rint(warped * gains[t]), 0, 255).astype(np.uint8)
    return dataclasses.replace(stimulus, frames=out, name=name)
