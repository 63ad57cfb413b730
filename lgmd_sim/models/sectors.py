"""One LGMD per sector of the view: a model of `lgmd_sim.models` over a grid of
overlapping parts of the frame, each with its own membrane potential and alarm.

The anchors steer by where the looming is: Gary2017's Unity testbed runs two LGMDs over
the overlapping 0-60% and 40-100% of the image width and turns away from the more
excited one; a UAV C-LGMD runs one per quadrant. `Sectors` does the same for every model:

>>> eyes = Sectors("feedback")                  # 2 x 1 sectors, overlapping 20% of the width
>>> out = eyes.step(frame)                       # out.potential: (2,) left, right
>>> quads = Sectors("lgmd1", preset="published+image", columns=2, rows=2, n_streams=8)

The sectors are the streams of one batched model (N cameras x S sectors), so every
sector keeps all of the model's temporal state and a sector sees its part of the frame
exactly as a model given that part alone would. A front end (``+image``, ``+imu``,
``+gain``...) estimates the camera's motion once on the whole frame; each sector's model
is warped by that motion seen from its crop (`sector_motion`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim import models
from lgmd_sim.core.params import CheckedParams, in_range, int_at_least, param
from lgmd_sim.models.base import LGMDOutput
from lgmd_sim.models.warp import Motion

__all__ = ["MIN_SECTOR", "SectorParams", "Sectors", "below_one", "sector_boxes", "sector_motion"]

#: The least height and width of a sector (pixels): below it the models' kernels (3x3
#: and wider) see mostly the border.
MIN_SECTOR = 4


def below_one(v: Any) -> str | None:
    """The check of an overlap: a number in [0, 1)."""
    error = in_range(0.0, 1.0)(v)
    return error if error or v < 1.0 else "must be a number in [0, 1)"


@dataclass(frozen=True)
class SectorParams(CheckedParams):
    """The grid of sectors."""

    columns: int = param(2, "Gary2017: two LGMDs side by side", check=int_at_least(1),
                         doc="sectors across the frame")
    rows: int = param(1, "Gary2017: two LGMDs side by side", check=int_at_least(1),
                      doc="sectors down the frame")
    overlap: float = param(0.2, "Gary2017: 0-60% and 40-100% of the image width",
                           check=below_one,
                           doc="neighbouring sectors share this fraction of the frame's "
                               "width (columns) or height (rows)")


def _spans(length: int, parts: int, overlap: float) -> list[tuple[int, int]]:
    """`parts` equal spans of 0..length, neighbours sharing `overlap` x length."""
    if parts == 1:
        return [(0, length)]
    # rounded up, so that the spans cover the frame (1e-9: 0.6 x 160 is 96, not 97)
    size = math.ceil(length * (1.0 + (parts - 1) * overlap) / parts - 1e-9)
    return [(s, s + size) for s in
            (math.floor(i * (length - size) / (parts - 1) + 0.5) for i in range(parts))]


def sector_boxes(height: int, width: int, columns: int = 2, rows: int = 1,
                 overlap: float = 0.2) -> list[tuple[int, int, int, int]]:
    """The sectors of a height x width frame as (top, bottom, left, right) pixel bounds
    (bottom and right exclusive), row by row, each row from left to right; all of one
    size, so that they batch."""
    p = SectorParams(columns, rows, overlap)
    return [(top, bottom, left, right) for top, bottom in _spans(height, p.rows, p.overlap)
            for left, right in _spans(width, p.columns, p.overlap)]


def sector_motion(motion: Motion, n: int, boxes: Sequence[tuple[int, int, int, int]]
                  ) -> Motion:
    """The motion of n cameras' frames (`Motion`) as each sector's crop sees it, for the
    n x len(boxes) streams of the sectors (camera-major): a homography H becomes
    T^-1 H T (T: crop pixels -> frame pixels), a horizon line l becomes l T, a gain
    field is cropped."""
    hs, gains, horizons, grounds = motion.per_stream(n)
    shift = np.array([[[1.0, 0.0, left], [0.0, 1.0, top], [0.0, 0.0, 1.0]]
                      for top, _b, left, _r in boxes])
    back = shift.copy()
    back[:, :2, 2] *= -1.0  # exact: T^-1 of a translation

    def conjugate(h: np.ndarray | None) -> np.ndarray | None:
        return None if h is None else (back[None] @ h[:, None] @ shift[None]).reshape(-1, 3, 3)

    if gains is not None:
        gains = (np.repeat(gains, len(boxes), axis=0) if gains.shape[1:] == (1, 1) else
                 np.stack([gains[:, t:b, le:r] for t, b, le, r in boxes], axis=1).reshape(
                     -1, boxes[0][1] - boxes[0][0], boxes[0][3] - boxes[0][2]))
    lines = None if horizons is None else (horizons[:, None, None] @ shift[None]).reshape(-1, 3)
    return Motion(conjugate(hs), gains, lines, conjugate(grounds))


class Sectors:
    """A model run over a grid of overlapping sectors of the frame, one LGMD each.

    ``step`` returns an `LGMDOutput` of the sectors: potentials and alarms (S,) for one
    camera, (N, S) for ``n_streams=N`` (row by row, each row from left to right: for the
    default 2 x 1, left and right); with ``layers=True`` each layer map (S, h, w) or
    (N, S, h, w), h x w the sectors' size.

    Args:
        name, preset, **params: the model, as `lgmd_sim.models.make` takes them (front
            ends included: "published+image").
        columns, rows, overlap: the grid (`SectorParams`).
        n_streams: None for one camera; N for N cameras at once.
    """

    def __init__(self, name: str, *, preset: str | None = None, columns: int = 2,
                 rows: int = 1, overlap: float = 0.2, n_streams: int | None = None,
                 **params: Any) -> None:
        self.grid = SectorParams(columns, rows, overlap)
        # The model over the whole frame checks the arguments, then the frames, and runs
        # the front end; it never steps, so it holds no maps.
        self._whole = models.make(name, preset=preset, n_streams=n_streams, **params)
        self.params = self._whole.params
        self.n_streams = n_streams
        self._n = 1 if n_streams is None else int(n_streams)
        self.n_sectors = self.grid.columns * self.grid.rows
        inner = self.params.replace(stabilize="none", gain=False)
        self.model = type(self._whole)(inner, n_streams=self._n * self.n_sectors)
        self.layer_names = self.model.layer_names
        #: The sectors (top, bottom, left, right) of the current frame size (`sector_boxes`);
        #: None before the first frame.
        self.boxes: list[tuple[int, int, int, int]] | None = None
        self.frame_shape: tuple[int, int] | None = None

    @property
    def threshold(self) -> float:
        return self.params.threshold

    @property
    def rotation_key(self) -> str | None:
        """As `LGMDModel.rotation_key`."""
        return self._whole.rotation_key

    def rotation_from(self, info: Mapping[str, Any] | Sequence[Mapping[str, Any]]
                      ) -> np.ndarray | None:
        """As `LGMDModel.rotation_from`."""
        return self._whole.rotation_from(info)

    def reset(self, streams: Sequence[int] | np.ndarray | None = None) -> None:
        """Start new cameras' streams: all of them (the frame size may then change), or
        those listed, every sector of each."""
        self._whole.reset(streams)  # checks the indices, resets the front end
        if streams is None:
            self.model.reset()
            self.frame_shape = self.boxes = None
            return
        idx = np.asarray(streams, np.intp).reshape(-1, 1)
        self.model.reset((idx * self.n_sectors + np.arange(self.n_sectors)).reshape(-1))

    def step(self, frame: np.ndarray, *, layers: bool = False, motion: Motion | None = None,
             rotation: np.ndarray | None = None) -> LGMDOutput:
        """Feed one frame (one per camera when batched): as `LGMDModel.step`, for every
        sector."""
        whole = self._whole
        grey = whole._to_grey_stack(frame)
        if whole.front_end is not None:
            if motion is not None:
                raise ValueError(f"{whole.name}: estimates its own motion; motion= is for "
                                 "models without a front end")
            motion = whole.front_end.motion(grey, rotation)
        elif rotation is not None:
            raise ValueError(f"{whole.name}: rotation= needs stabilize='pose' or 'imu'")
        shape = (grey.shape[1], grey.shape[2])
        if self.frame_shape is None:
            boxes = sector_boxes(*shape, self.grid.columns, self.grid.rows, self.grid.overlap)
            top, bottom, left, right = boxes[0]
            if min(bottom - top, right - left) < MIN_SECTOR:
                raise ValueError(f"sectors: {self.grid.columns} x {self.grid.rows} sectors of "
                                 f"a {shape[0]}x{shape[1]} frame are {bottom - top}x"
                                 f"{right - left} pixels; each needs {MIN_SECTOR}x{MIN_SECTOR}")
            self.frame_shape, self.boxes = shape, boxes
        elif shape != self.frame_shape:
            raise ValueError(f"{whole.name}: frame size {shape[0]}x{shape[1]} differs from "
                             f"this stream's {self.frame_shape[0]}x{self.frame_shape[1]}; "
                             "call reset() to start a new stream")
        # uint8 grey goes in as it is; float frames as given, so that the model scales
        # them to 0..255 exactly as it would scale the whole frame
        frames = grey if grey.dtype == np.uint8 else (
            np.asarray(frame) if whole.batched else np.asarray(frame)[None])
        crops = np.stack([frames[:, t:b, le:r] for t, b, le, r in self.boxes], axis=1)
        out = self.model.step(crops.reshape(-1, *crops.shape[2:]), layers=layers,
                              motion=None if motion is None else
                              sector_motion(motion, self._n, self.boxes))
        lead = (self._n, self.n_sectors) if whole.batched else (self.n_sectors,)
        maps = None if out.layers is None else {
            k: v.reshape(*lead, *v.shape[1:]) for k, v in out.layers.items()}
        return LGMDOutput(out.potential.reshape(lead), out.alarm.reshape(lead), maps)
