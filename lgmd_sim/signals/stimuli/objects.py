"""An object in a small pinhole-camera world: looming, receding, crossing or at rest.

The object (a dark or light square or disc, as its `Look` says) of half-size ``half_size``
metres at distance ``d`` on the optical axis has the angular size ``2 atan(half_size / d)``
and is drawn with exact area coverage at its edges, so a looming edge moves smoothly by
fractions of a pixel. Every moving stimulus starts with ``still_frames`` identical frames
so that a model begins at rest.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.core.params import CheckedParams, int_at_least, one_of, param, positive
from lgmd_sim.signals.stimuli.clip import (
    BACKGROUNDS,
    Stimulus,
    count,
    draw_background,
    fraction,
    frame_shape,
    positive_float,
    to_uint8,
)

DESIGN = "design choice"


def _field_of_view(value: Any) -> str | None:
    # a pinhole camera sees less than a half space: tan(fov / 2) is infinite at 180
    return None if positive(value) is None and value < 180 else "must be a number in (0, 180)"


@dataclass(frozen=True)
class Look(CheckedParams):
    """How the object looks: its grey level against the background, its form and size,
    and the camera's field of view. One `Look` serves every stimulus of this module.

    The object and the background sit symmetrically about mid-grey, ``contrast`` apart: a
    dark object on a light background, or a light one on a dark background.
    """

    polarity: str = param("dark", DESIGN, check=one_of("dark", "light"),
                          doc='"dark" (a dark object on a light background) or "light"')
    form: str = param("square", DESIGN, check=one_of("square", "disc"), doc='"square" or "disc"')
    half_size: float = param(0.1, "design: half-size over the default 2 m/s approach is 50 ms",
                             check=positive,
                             doc="the object's half-side (square) or radius (disc), metres")
    contrast: float = param(0.8, DESIGN, check=fraction,
                            doc="grey-level difference of object and background, in (0, 1]")
    background: str = param("uniform", DESIGN, check=one_of(*BACKGROUNDS),
                            doc='"uniform" or "texture" (a seeded smooth random texture)')
    seed: int = param(0, DESIGN, check=int_at_least(0), doc="seed of the texture")
    fov: float = param(60.0, DESIGN, check=_field_of_view,
                       doc="horizontal field of view, degrees")

    def focal_px(self, width: int) -> float:
        """Focal length in pixels of a view ``width`` pixels wide."""
        return (width / 2) / math.tan(math.radians(float(self.fov)) / 2)


def _render(
    motion: str,
    shape: tuple[int, int],
    look: Look,
    fps: float,
    distances: np.ndarray,
    centres_x: np.ndarray | None = None,
    collision_frame: int | None = None,
    angles: np.ndarray | None = None,
) -> Stimulus:
    """Draw the object at the given distance (and image column of its centre, and turn
    about the line of sight, radians) per frame."""
    half_size = float(look.half_size)
    contrast = float(look.contrast)
    sign = 1.0 if look.polarity == "dark" else -1.0
    bg = draw_background(shape, 0.5 + sign * contrast / 2, look.background, look.seed)
    level = 0.5 - sign * contrast / 2
    focal = look.focal_px(shape[1])
    cy, cx0 = (shape[0] - 1) / 2, (shape[1] - 1) / 2
    frames = np.empty((len(distances), *shape), np.uint8)
    for t, d in enumerate(distances):
        half_px = focal * half_size / d if d > 0 else math.inf
        cx = cx0 if centres_x is None else centres_x[t]
        cov = (_coverage(shape, look.form, cx, cy, half_px) if angles is None
               else _turned_square(shape, cx, cy, half_px, float(angles[t])))
        frames[t] = to_uint8(bg + (level - bg) * cov)
    angular = np.where(
        distances > 0, 2 * np.arctan(half_size / np.maximum(distances, 1e-12)), math.pi
    )
    return Stimulus(frames, fps, collision_frame, f"{motion} {look.polarity} {look.form}",
                    angular)


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


def approaching(
    shape: Sequence[int] = (120, 160),
    *,
    start_distance: float = 3.0,
    speed: float = 2.0,
    still_frames: int = 5,
    fps: float = 30.0,
    look: Look = Look(),
) -> Stimulus:
    """An object looming at constant speed straight at the eye, up to collision.

    With the defaults (a 0.2 m square from 3 m at 2 m/s, half-size over speed 50 ms, a
    60 degree view) the object grows from 9 pixels across to fill the 160 x 120 view in
    the last few frames; the clip ends on the collision frame (the first with distance
    <= 0, the object covering the whole view).

    :param shape: (height, width) of the frames.
    :param start_distance: distance when the motion starts, metres.
    :param speed: approach speed, metres per second.
    :param still_frames: identical frames before the motion starts.
    :param fps: frames per second.
    :param look: how the object looks.
    :return: the clip, its collision frame the last.
    """
    shape = frame_shape(shape)
    start_distance = positive_float("start_distance", start_distance)
    speed = positive_float("speed", speed)
    still_frames = count("still_frames", still_frames, 0)
    fps = positive_float("fps", fps)
    n_motion = math.ceil(start_distance * fps / speed - 1e-9)
    motion = start_distance - speed * np.arange(n_motion + 1) / fps
    distances = np.concatenate([np.full(still_frames, start_distance), motion])
    return _render("approaching", shape, look, fps, distances,
                   collision_frame=still_frames + n_motion)


def receding(
    shape: Sequence[int] = (120, 160),
    *,
    near_distance: float = 0.5,
    end_distance: float = 3.0,
    speed: float = 2.0,
    still_frames: int = 5,
    fps: float = 30.0,
    look: Look = Look(),
) -> Stimulus:
    """An object moving straight away at constant speed: the time reverse of an approach.

    It is the reverse of an approach from ``end_distance`` to ``near_distance``, which
    stops short of collision: a recession starting from an object that fills the whole
    view would begin with a step change of the image. With the defaults the object starts
    55 pixels across (about half the view's height).

    :param near_distance: the distance it starts from, metres.
    :param end_distance: the distance it stops at, metres; beyond ``near_distance``.
    :param speed: receding speed, metres per second.
    Others as in `approaching`.
    """
    shape = frame_shape(shape)
    near_distance = positive_float("near_distance", near_distance)
    end_distance = positive_float("end_distance", end_distance)
    if end_distance <= near_distance:
        raise ValueError(f"end_distance ({end_distance}) must exceed near_distance "
                         f"({near_distance})")
    speed = positive_float("speed", speed)
    still_frames = count("still_frames", still_frames, 0)
    fps = positive_float("fps", fps)
    n_motion = math.ceil((end_distance - near_distance) * fps / speed - 1e-9)
    motion = np.minimum(near_distance + speed * np.arange(n_motion + 1) / fps, end_distance)
    distances = np.concatenate([np.full(still_frames, near_distance), motion])
    return _render("receding", shape, look, fps, distances)


def translating(
    shape: Sequence[int] = (120, 160),
    *,
    distance: float = 0.5,
    speed: float = 1.0,
    still_frames: int = 5,
    fps: float = 30.0,
    look: Look = Look(),
) -> Stimulus:
    """An object of constant size crossing the view from left to right at constant speed.

    It enters from just outside the left border and leaves fully past the right one;
    the still frames show the background alone. With the defaults the object is 55
    pixels across (as a receding one starts) and moves 9.2 pixels per frame, between
    the edge speeds of the default approach at 0.5 m (3.7) and 0.25 m (14.8) from the eye.

    :param distance: the object's distance, metres (sets its image size).
    :param speed: lateral speed, metres per second.
    Others as in `approaching`.
    """
    shape = frame_shape(shape)
    distance = positive_float("distance", distance)
    speed = positive_float("speed", speed)
    still_frames = count("still_frames", still_frames, 0)
    fps = positive_float("fps", fps)
    focal = look.focal_px(shape[1])
    half_px = focal * float(look.half_size) / distance
    step_px = focal * speed / distance / fps
    n_motion = math.ceil((shape[1] + 2 * half_px) / step_px)
    start = -0.5 - half_px  # right edge on the left border of the first column
    # the still frames park the object far outside the view
    centres = np.concatenate([np.full(still_frames, -1e9),
                              start + step_px * np.arange(n_motion + 1)])
    return _render("translating", shape, look, fps, np.full(len(centres), distance), centres)


#: Samples per pixel side of a turned square's coverage (its edges are not on the axes).
_SUPERSAMPLE = 4


def _turned_square(shape: tuple[int, int], cx: float, cy: float, half: float, angle: float
                   ) -> np.ndarray:
    """Fraction of each pixel covered by a square of half-side ``half`` turned by `angle`
    (radians) about its centre: `_SUPERSAMPLE` x `_SUPERSAMPLE` samples per pixel."""
    h, w = shape
    n = _SUPERSAMPLE
    offsets = (np.arange(n) + 0.5) / n - 0.5
    y = (np.arange(h)[:, None] + offsets[None, :]).reshape(-1) - cy
    x = (np.arange(w)[:, None] + offsets[None, :]).reshape(-1) - cx
    c, s = math.cos(angle), math.sin(angle)
    u = c * x[None, :] + s * y[:, None]  # the square's own axes
    v = -s * x[None, :] + c * y[:, None]
    inside = (np.abs(u) <= half) & (np.abs(v) <= half)
    return inside.reshape(h, n, w, n).mean(axis=(1, 3))


def rotating(
    shape: Sequence[int] = (120, 160),
    *,
    distance: float = 1.0,
    rate: float = 180.0,
    n_frames: int = 60,
    still_frames: int = 5,
    fps: float = 30.0,
    look: Look = Look(),
) -> Stimulus:
    """A square at rest in the middle of the view, turning about the line of sight at a
    constant rate: its edges sweep, its size stays. Always a square (a turning disc looks
    still), whatever ``look.form``.

    :param distance: the object's distance, metres (sets its image size: 27 pixels across
        with the defaults).
    :param rate: turning rate, degrees per second.
    :param n_frames: frames of turning (after the still frames).
    Others as in `approaching`.
    """
    shape = frame_shape(shape)
    distance = positive_float("distance", distance)
    rate = positive_float("rate", rate)
    n_frames = count("n_frames", n_frames, 1)
    still_frames = count("still_frames", still_frames, 0)
    fps = positive_float("fps", fps)
    angles = np.radians(rate) / fps * np.concatenate(
        [np.zeros(still_frames), np.arange(n_frames)])
    square = dataclasses.replace(look, form="square")
    return _render("rotating", shape, square, fps, np.full(len(angles), distance),
                   angles=angles)


def static(
    shape: Sequence[int] = (120, 160),
    *,
    n_frames: int = 30,
    distance: float = 1.0,
    fps: float = 30.0,
    look: Look = Look(background="texture"),
) -> Stimulus:
    """A still scene: the object at rest, by default before a textured background; every
    frame identical.

    :param n_frames: number of frames.
    :param distance: the object's distance, metres.
    Others as in `approaching`.
    """
    shape = frame_shape(shape)
    n_frames = count("n_frames", n_frames, 1)
    distance = positive_float("distance", distance)
    fps = positive_float("fps", fps)
    return _render("static", shape, look, fps, np.full(n_frames, distance))
