"""Full-field stimuli without an object: a drifting grating and whole-field flicker."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from lgmd_sim.core.params import checked, finite, one_of
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

WAVEFORMS = ("sine", "square")


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

    :param shape: (height, width) of the frames.
    :param period: spatial period, pixels.
    :param speed: drift speed across the bars, pixels per second.
    :param orientation: direction of drift, degrees (0: vertical bars drifting rightwards).
    :param waveform: "sine" or "square".
    :param contrast: peak-to-peak amplitude about mid-grey, in (0, 1].
    :param n_frames: frames of motion (after the still frames).
    :param still_frames: identical frames before the motion starts.
    :param fps: frames per second.
    :return: the clip (no object, no collision).
    """
    h, w = frame_shape(shape)
    period = positive_float("period", period)
    speed = positive_float("speed", speed)
    fps = positive_float("fps", fps)
    checked("orientation", orientation, finite)
    checked("waveform", waveform, one_of(*WAVEFORMS))
    contrast = float(checked("contrast", contrast, fraction))
    n_frames = count("n_frames", n_frames, 1)
    ss = 1 if waveform == "sine" else 4
    offs = (np.arange(ss) + 0.5) / ss - 0.5  # sub-pixel sample positions
    ys = (np.arange(h)[:, None] + offs[None, :]).reshape(-1)
    xs = (np.arange(w)[:, None] + offs[None, :]).reshape(-1)
    theta = math.radians(orientation)
    along = xs[None, :] * math.cos(theta) + ys[:, None] * math.sin(theta)
    shifts = np.concatenate([np.zeros(count("still_frames", still_frames, 0)),
                             speed * np.arange(n_frames) / fps])
    frames = np.empty((len(shifts), h, w), np.uint8)
    for t, s in enumerate(shifts):
        img = 0.5 + contrast / 2 * _wave(2 * math.pi * (along - s) / period, waveform)
        if ss > 1:
            img = img.reshape(h, ss, w, ss).mean(axis=(1, 3))
        frames[t] = to_uint8(img)
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

    :param shape: (height, width) of the frames.
    :param frequency: modulation frequency, Hz.
    :param depth: modulation depth, in (0, 1].
    :param waveform: "sine" or "square".
    :param background: "uniform" (mid-grey) or "texture" (mid-grey, seeded texture).
    :param n_frames: frames of modulation (after the still frames).
    :param still_frames: unmodulated frames before the modulation starts.
    :param fps: frames per second.
    :param seed: seed of the texture.
    :return: the clip (no object, no collision).
    """
    shape = frame_shape(shape)
    frequency = positive_float("frequency", frequency)
    depth = float(checked("depth", depth, fraction))
    checked("waveform", waveform, one_of(*WAVEFORMS))
    fps = positive_float("fps", fps)
    n_frames = count("n_frames", n_frames, 1)
    checked("background", background, one_of(*BACKGROUNDS))
    scene = draw_background(shape, 0.5, background, count("seed", seed, 0))
    t = np.arange(n_frames) / fps
    gains = np.concatenate([np.ones(count("still_frames", still_frames, 0)),
                            1 + depth * _wave(2 * math.pi * frequency * t, waveform)])
    frames = to_uint8(gains[:, None, None] * scene[None])
    return Stimulus(frames, fps, None, f"{waveform} flicker {frequency:g} Hz", None)
