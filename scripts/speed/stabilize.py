"""`python -m scripts.speed stabilize`: time per frame of each ego-motion front end, on one core.

The frames are a far textured scene seen by a camera that turns by a seeded, random
rotation of about 1 degree per frame (hand-held shake), so the image fit has real work.
Measured in one run: the image-only rotation fit alone, the brightness gain alone, one
warp of a frame (the least any front end that moves a stored map costs), and per model the
time per frame without a front end and with each of "pose" (the warp of every stored map
by a given rotation), "image" (fit and warp) and "image+gain" at the frames' size, and at
its `video` preset (image+gain on frames shrunk to the preset's ``working_height``), whose
cost over the bare model's has a target (`VIDEO_TARGET`).
"""

from __future__ import annotations

import platform
import sys
import time
from collections.abc import Callable

import numpy as np

from lgmd_sim.core.machine import cpu_name
from scripts.speed import format_table, met, pin_to_one_core

__all__ = ["rotating_scene", "run"]

#: Each figure is the best of this many runs (others on the machine only slow one down).
RUNS = 5
#: Front ends timed with every model at the frames' size, as preset suffixes ("" is
#: none); the `video` presets' is the last, which they run at their ``working_height``.
FRONTS = ("", "pose", "image", "image+gain")
#: The target: a `video` preset at most this many times the bare model's time per frame.
VIDEO_TARGET = 2.0


def rotating_scene(height: int, width: int, n: int, seed: int = 0, degrees: float = 1.0
                   ) -> tuple[np.ndarray, np.ndarray]:
    """n uint8 frames of a far texture seen by a turning camera, and each frame's turn
    since the previous one (rotation vectors, rad; 0 for frame 0)."""
    import cv2

    from lgmd_sim.models.stabilize import intrinsics, rotation_homography

    rng = np.random.default_rng(seed)
    texture = cv2.GaussianBlur(rng.integers(0, 256, (3 * height, 3 * width)).astype(
        np.float32), (0, 0), 2.0)
    texture = cv2.normalize(texture, None, 0, 255, cv2.NORM_MINMAX)
    k = intrinsics(55.0, height, width)
    turns = np.vstack([np.zeros(3), np.radians(degrees) * rng.normal(size=(n - 1, 3))])
    pose = np.array([[1.0, 0, -width], [0, 1, -height], [0, 0, 1]])  # the middle third
    frames = []
    for r in turns:
        pose = rotation_homography(r, k) @ pose
        frames.append(cv2.warpPerspective(texture, pose, (width, height)))
    return np.clip(np.stack(frames) + 0.5, 0, 255).astype(np.uint8), turns


def _per_frame_ms(make: Callable[[], Callable[[int], object]], n_frames: int) -> float:
    """Milliseconds per call of step(i), i = 0..n_frames-1, on a fresh `make()` each run
    (a stream starts each time): the best of RUNS runs."""
    best = float("inf")
    for _ in range(RUNS + 1):  # the first run warms up (numba loads its cache)
        step = make()
        start = time.perf_counter()
        for i in range(n_frames):
            step(i)
        best = min(best, (time.perf_counter() - start) / n_frames)
    return 1000.0 * best


def run(*, height: int = 270, width: int = 480, frames: int = 60,
        markdown: bool = False) -> int:
    """Time every front end and print the table (Markdown with ``--markdown``)."""
    import cv2

    from lgmd_sim import models
    from lgmd_sim.models.stabilize import (
        ImageRotation,
        brightness_gain,
        intrinsics,
        rotation_homography,
    )

    where = pin_to_one_core()
    frames, turns = rotating_scene(height, width, frames)
    n = len(frames)
    print(f"# python -m scripts.speed stabilize: {height}x{width} uint8 frames of a camera "
          f"turning about 1 degree per frame, best of {RUNS} runs of {n} frames, one core")
    print(f"# CPU: {cpu_name()}, {where}; Python {platform.python_version()}")

    def fit() -> Callable[[int], object]:
        tracker = ImageRotation(55.0)
        return lambda i: tracker.update(frames[i])

    fit_ms = _per_frame_ms(fit, n)
    gain_ms = _per_frame_ms(lambda: lambda i: brightness_gain(frames[i - 1], frames[i], None), n)
    k = intrinsics(55.0, height, width)
    warp_ms = _per_frame_ms(lambda: lambda i: cv2.warpPerspective(
        frames[i - 1], rotation_homography(turns[i], k), (width, height)), n)
    print(format_table(["front end alone", "ms per frame"],
                       [["image: rotation fit (ImageRotation.update)", f"{fit_ms:.2f}"],
                        ["gain: brightness gain (brightness_gain)", f"{gain_ms:.2f}"],
                        ["one warp of the previous frame (cv2.warpPerspective)",
                         f"{warp_ms:.2f}"]],
                       markdown))
    print()
    body = []
    for name in models.available():
        ms = []
        for front in FRONTS:
            preset = models.parse_spec(f"{name}+{front}" if front else name)[1]

            def stream(name: str = name, preset: str = preset) -> Callable[[int], object]:
                m = models.make(name, preset=preset)
                key = m.rotation_key
                return lambda i: m.step(frames[i], rotation=None if key is None else turns[i])

            ms.append(_per_frame_ms(stream, n))
        if "video" in models.presets_of(name):
            ms.append(_per_frame_ms(lambda name=name: stream(name, "video"), n))
            ratio = ms[-1] / ms[0]
            body.append([name, *(f"{t:.2f}" for t in ms), f"{ratio:.1f}x",
                         met(ratio <= VIDEO_TARGET)])
        else:
            body.append([name, *(f"{t:.2f}" for t in ms), "", "", "no video preset"])
        print(f"measured {name}", file=sys.stderr, flush=True)
    print(format_table(["model (ms per frame)", "no front end", "+pose (warp)", "+image",
                        "+image+gain", "video preset", "video / none",
                        f"target {VIDEO_TARGET:g}x"], body, markdown))
    return 0
