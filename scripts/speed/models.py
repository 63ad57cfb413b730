"""`python -m scripts.speed models`: frames per second of every LGMD model on one core.

For each model of `lgmd_sim.models.available()`: streaming frames/s (one stream, one
frame per step), batched frames/s (N streams per step; frames counted over all streams),
the frames/s of its per-equation reference implementation, and the ratio of streaming
to reference, all measured in the same run on the same frames. The process is pinned to
one core and every library to one thread. Frames come from a random texture moving
diagonally, so every pixel changes and the kernels do their full work.

With ``--published FILE`` (the user's copy of the published Python LGMD, which this
project does not ship): its frames/s on `PUBLISHED_FRAMES` frames at `PUBLISHED_SIZE`,
read from a lossless video as its class is written to do, against the feedback LGMD
streaming the same frames, in the same run (`PUBLISHED_TARGET`).
"""

from __future__ import annotations

import importlib.util
import platform
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lgmd_sim.core.machine import cpu_name
from scripts.speed import format_table, met, pin_to_one_core

__all__ = ["Row", "measure", "moving_texture", "run"]

#: Warm-up steps before timing: numba compiles (or loads its cache) on the first call.
WARMUP_STEPS = 5
#: Each fast figure is the best of this many runs: on a shared machine, other processes
#: only ever slow a run down.
RUNS = 5
#: A reference stops after this many seconds (it is slow), with at least MIN_FRAMES.
REFERENCE_BUDGET_S = 10.0
MIN_FRAMES = 3


@dataclass(frozen=True)
class Row:
    """One model's figures; None where not measured, with the reason in ``note``."""

    model: str
    streaming: float | None = None
    batched: float | None = None
    reference: float | None = None
    note: str = ""

    @property
    def ratio(self) -> float | None:
        if self.streaming is None or self.reference is None:
            return None
        return self.streaming / self.reference


def moving_texture(height: int, width: int, n: int, seed: int = 0) -> np.ndarray:
    """n uint8 frames: a window moving 3 px right and 2 px down per frame over a texture.

    The texture is uniform noise smoothed over about 2 pixels (grey levels 0..255), so
    every pixel changes every frame, as under a shaking camera.
    """
    import cv2

    rng = np.random.default_rng(seed)
    big = rng.integers(0, 256, (height + 2 * n + 8, width + 3 * n + 8), dtype=np.uint8)
    big = cv2.GaussianBlur(big, (5, 5), 1.0)
    big = cv2.normalize(big, None, 0, 255, cv2.NORM_MINMAX)
    return np.stack([big[2 * t : 2 * t + height, 3 * t : 3 * t + width] for t in range(n)])


def _rate(step: Callable[[int], object], n_frames: int, budget_s: float | None = None) -> float:
    """Steps per second over n_frames calls of step(i): the best of RUNS runs.

    With ``budget_s`` (for slow references): one run, stopped once budget_s is spent.
    """
    for i in range(WARMUP_STEPS if budget_s is None else 1):
        step(i)
    best = 0.0
    for _ in range(1 if budget_s is not None else RUNS):
        done = 0
        start = time.perf_counter()
        while done < n_frames:
            step(done)
            done += 1
            if budget_s is not None and done >= MIN_FRAMES and (
                time.perf_counter() - start > budget_s
            ):
                break
        best = max(best, done / (time.perf_counter() - start))
    return best


def measure(name: str, frames: np.ndarray, n_frames: int, n_streams: int) -> Row:
    """Streaming, batched and reference frames/s of model `name` on `frames`."""
    from lgmd_sim import models
    from lgmd_sim.models.reference import make_reference

    try:
        model = models.make(name)
    except ImportError as exc:
        return Row(name, note=f"not available ({exc})")
    cycle = len(frames)
    streaming = _rate(lambda i: model.step(frames[i % cycle]), n_frames)
    batch_model = models.make(name, n_streams=n_streams)
    offsets = np.arange(n_streams) * 7  # every stream sees other frames
    stacks = [np.ascontiguousarray(frames[(offsets + i) % cycle]) for i in range(cycle)]
    batched = n_streams * _rate(lambda i: batch_model.step(stacks[i % cycle]),
                                max(1, n_frames // n_streams))
    try:
        ref = make_reference(name)
    except ValueError as exc:
        return Row(name, streaming, batched, note=f"no reference ({exc})")
    reference = _rate(lambda i: ref.step(frames[i % cycle]), n_frames, REFERENCE_BUDGET_S)
    return Row(name, streaming, batched, reference)


#: The targets, streaming frames per second at 270 x 480 on one core: every model's, and
#: the feedback LGMD's own.
TARGET_FPS, FEEDBACK_TARGET_FPS = 500, 2000


#: The published Python LGMD's comparison: its class, the frame size and clip length of
#: the timing on record (a 240 x 432 dashcam clip of 90 frames), and the target ratio of
#: the feedback LGMD's streaming frames/s to its.
PUBLISHED_CLASS = "LGMD_P_ON_OFF"
PUBLISHED_SIZE, PUBLISHED_FRAMES, PUBLISHED_TARGET = (240, 432), 90, 200


def published_rate(path: Path, frames: np.ndarray) -> float:
    """Frames/s of the published Python LGMD (`PUBLISHED_CLASS` of the file `path`) on
    grey `frames`: written to a lossless video, which it reads and processes whole, as its
    ``run()`` does (one run: it is slow)."""
    from lgmd_sim.signals.video import video_writer

    spec = importlib.util.spec_from_file_location("published_lgmd", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    cls = getattr(module, PUBLISHED_CLASS, None)
    if cls is None:
        raise ValueError(f"--published {path}: it has no class {PUBLISHED_CLASS}")
    with tempfile.TemporaryDirectory(prefix="lgmd-sim-speed-") as tmp:
        clip = Path(tmp) / "clip.mkv"
        with video_writer(clip, 30, frames.shape[1:]) as write:
            for grey in frames:
                write(np.repeat(grey[..., None], 3, axis=-1))
        start = time.perf_counter()
        cls(str(clip)).run()
        return len(frames) / (time.perf_counter() - start)


def _published_table(path: Path, markdown: bool) -> str:
    """The feedback LGMD against the published Python LGMD on the same frames."""
    from lgmd_sim import models

    frames = moving_texture(*PUBLISHED_SIZE, PUBLISHED_FRAMES)
    model = models.make("feedback")
    ours = _rate(lambda i: model.step(frames[i % len(frames)]), len(frames))
    theirs = published_rate(path, frames)
    ratio = ours / theirs
    h, w = PUBLISHED_SIZE
    return format_table(
        ["model", f"streaming fps at {h}x{w}", f"published Python LGMD fps ({path.name})",
         "ratio", f"target {PUBLISHED_TARGET}x"],
        [["feedback", f"{ours:,.0f}", f"{theirs:.1f}", f"{ratio:.0f}x",
          met(ratio >= PUBLISHED_TARGET)]], markdown)


def _table(rows: list[Row], n_streams: int, markdown: bool) -> str:
    head = ["model", "streaming fps", f"batched fps ({n_streams} streams)", "reference fps",
            "fast / reference", "target fps (streaming)"]

    def fmt(v: float | None, suffix: str = "") -> str:
        return "-" if v is None else f"{v:,.0f}{suffix}" if v >= 10 else f"{v:.1f}{suffix}"

    def target(r: Row) -> str:
        fps = FEEDBACK_TARGET_FPS if r.model == "feedback" else TARGET_FPS
        return f"{fps:,}: {met(r.streaming >= fps)}"

    body = [[r.model, fmt(r.streaming), fmt(r.batched), fmt(r.reference), fmt(r.ratio, "x"),
             target(r)] for r in rows]
    notes = [f"{r.model}: {r.note}" for r in rows if r.note]
    return "\n".join([format_table(head, body, markdown), *(["", *notes] if notes else [])])


def run(*, height: int = 270, width: int = 480, frames: int = 300, streams: int = 8,
        published: Path | None = None, markdown: bool = False) -> int:
    """Measure every model and print the table (Markdown with ``--markdown``); with
    `published`, the feedback LGMD against that file's published Python LGMD too."""
    import numba

    from lgmd_sim import models

    if published is not None and not published.is_file():  # before minutes of timing
        raise ValueError(f"--published {published}: no such file")
    where = pin_to_one_core()
    clip = moving_texture(height, width, 64)
    print(f"# python -m scripts.speed models: {height}x{width} uint8 frames, best of "
          f"{RUNS} runs of {frames} frames (references: one run), one core")
    print(f"# CPU: {cpu_name()}, {where}; Python {platform.python_version()}, "
          f"numpy {np.__version__}, numba {numba.__version__}")
    rows = []
    for name in models.available():
        rows.append(measure(name, clip, frames, streams))
        print(f"measured {name}", file=sys.stderr, flush=True)
    print(_table(rows, streams, markdown))
    if published is not None:
        print()
        print(_published_table(published, markdown))
    return 0
