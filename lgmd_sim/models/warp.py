"""Warping a model's stored maps into the current camera frame (ego-motion compensation).

A per-frame motion estimate is a 3x3 homography H per stream that maps pixel coordinates
of the previous frame to those of the current one (x_t ~ H x_{t-1}; pixel (x, y) is
column x, row y, pixel centres at integers). Warping a stored map m gives
m'(x) = m(H^-1 x), bilinearly interpolated; a pixel whose source lies outside the
previous frame is *uncovered* and gets a fill value instead (the model decides which:
the current frame for its previous frame, so that P = 0 there, zero for the rest).

The sampling plan (source cell and weights of every pixel) is computed once per stream
and frame (`homography_plan`) and applied to every map of that stream (`apply_plan`), so
that all of a model's maps move exactly alike. Everything is per stream, so a batch is
warped exactly as separate streams are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from lgmd_sim.models.kernels import JIT, REFLECT, ZERO

__all__ = ["Motion", "Plan", "apply_plan", "fill_pad_columns", "homography_plan"]

# The kernels compile with `JIT`, so that a stream is warped to the same bits in
# any batch.



@dataclass(frozen=True)
class Motion:
    """The camera's motion between the previous frame and this one, per stream.

    Attributes:
        homography: (3, 3), or (N, 3, 3) for a batch: previous -> current pixel
            coordinates; None for no warp.
        gain: the brightness of this frame over the previous one's: a number, (N,), or a
            gain field per pixel, (H, W) or (N, H, W); the previous frame is multiplied by
            it; None for 1.
        horizon: a line (a, b, c), or (N, 3): the pixels (x, y) of the current frame with
            a x + b y + c > 0 (below the horizon, on the ground) move by ``ground``
            instead of ``homography``; None for none.
        ground: the homography of the pixels below the horizon, (3, 3) or (N, 3, 3); None
            with a horizon: those pixels are treated as uncovered (no change there).
    """

    homography: np.ndarray | None = None
    gain: float | np.ndarray | None = None
    horizon: np.ndarray | None = None
    ground: np.ndarray | None = None

    def per_stream(self, n: int) -> tuple[np.ndarray | None, np.ndarray | None,
                                          np.ndarray | None, np.ndarray | None]:
        """Per stream, checked: homographies (N, 3, 3) or None, gains (float32 (N, 1, 1)
        or fields (N, H, W)) or None, horizons (N, 3) or None, ground homographies
        (N, 3, 3) or None (float64)."""
        hs = _stack(self.homography, (3, 3), n, "homography")
        horizons = _stack(self.horizon, (3,), n, "horizon")
        grounds = _stack(self.ground, (3, 3), n, "ground")
        if hs is None and (horizons is not None or grounds is not None):
            raise ValueError("motion: a horizon or ground needs a homography")
        if grounds is not None and horizons is None:
            raise ValueError("motion: a ground homography needs a horizon")
        gains = None
        if self.gain is not None:
            g = np.asarray(self.gain, np.float32)
            if g.ndim < 2:  # a number, or one per stream
                g = np.broadcast_to(g, (n,)).reshape(n, 1, 1) if g.size in (1, n) else g
            elif g.ndim == 2 and n == 1:  # a stream's field
                g = g[None]
            if g.ndim != 3 or len(g) != n or not (np.isfinite(g).all() and (g > 0).all()):
                raise ValueError(f"motion: gain must be finite and > 0: a number, {n} of them "
                                 f"or gain fields ({n}, H, W), got shape {np.shape(self.gain)}")
            gains = g
        return hs, gains, horizons, grounds


def _stack(value: np.ndarray | None, shape: tuple[int, ...], n: int, what: str
           ) -> np.ndarray | None:
    """`value` of `shape`, or n of them, as (n, *shape) float64; None stays None."""
    if value is None:
        return None
    a = np.asarray(value, np.float64)
    if a.shape == shape:
        a = np.broadcast_to(a, (n, *shape))
    if a.shape != (n, *shape) or not np.isfinite(a).all():
        raise ValueError(f"motion: {what} must be finite, of shape {shape} or {(n, *shape)}, "
                         f"got {np.shape(value)}")
    return a


class Plan:
    """Where each pixel of a (height, width) frame comes from in the previous frame.

    Attributes:
        offset: (H, W) int32 top-left source cell (y0, x0) of each pixel, as the flat
            index y0 (W + 1) + x0 into a source with rows of W + 1 (see `apply_plan`).
        weights: (4, H, W) float32 bilinear weights of the source cells (y0, x0),
            (y0, x0 + 1), (y0 + 1, x0), (y0 + 1, x0 + 1); all 0 where uncovered.
        uncovered: (H, W) float32, 1 where the source lies outside the previous frame.
    """

    __slots__ = ("offset", "uncovered", "weights")

    def __init__(self, height: int, width: int) -> None:
        self.offset = np.zeros((height, width), np.int32)
        self.weights = np.zeros((4, height, width), np.float32)
        self.uncovered = np.zeros((height, width), np.float32)


def homography_plan(h: np.ndarray, plan: Plan, horizon: np.ndarray | None = None,
                    ground: np.ndarray | None = None) -> None:
    """Fill `plan` for the homography `h` (3x3, previous -> current pixel coordinates);
    with a `horizon` line, the pixels below it by the homography `ground`, or (None)
    uncovered (see `Motion`)."""
    hinv = np.linalg.inv(np.asarray(h, np.float64))
    line = np.array([0.0, 0.0, -1.0]) if horizon is None else np.asarray(horizon, np.float64)
    below = hinv if ground is None else np.linalg.inv(np.asarray(ground, np.float64))
    _plan(hinv, line, below, ground is not None, plan.offset, plan.weights, plan.uncovered)


@njit(**JIT)
def _plan(hinv_above, line, hinv_below, ground, offset, weights, uncovered):
    """Each row in at most two spans, above and below the horizon (the line is straight,
    so each side of it is a run of the row), each in two branch-free loops that LLVM
    vectorises (one loop writing all six outputs it did not: 5x slower)."""
    height, width = offset.shape
    sx = np.empty(width)
    sy = np.empty(width)
    for y in range(height):
        a = line[0]
        c = line[1] * y + line[2]  # below the horizon where a x + c > 0
        cut = width if a == 0.0 else min(max(int(-c / a), -1), width)
        while 0 <= cut < width and (a * cut + c > 0.0) == (a > 0.0):  # the exact edge
            cut -= 1
        while cut + 1 < width and (a * (cut + 1) + c > 0.0) != (a > 0.0):
            cut += 1
        cut += 1  # now x < cut is one side, x >= cut the other
        if a == 0.0:
            below_first, cut = c > 0.0, width
        else:
            below_first = a < 0.0
        _span(hinv_above, hinv_below, ground, below_first, y, 0, cut, sx, sy, offset,
              weights, uncovered)
        _span(hinv_above, hinv_below, ground, not below_first, y, cut, width, sx, sy, offset,
              weights, uncovered)


@njit(**JIT)
def _span(hinv_above, hinv_below, ground, is_below, y, lo, hi, sx, sy, offset, weights,
          uncovered):
    """The plan of pixels lo..hi-1 of row y, all on one side of the horizon."""
    if lo >= hi:
        return
    if is_below and not ground:
        _uncovered_span(y, lo, hi, offset, weights, uncovered)
        return
    height = offset.shape[0]
    _source_span(hinv_below if is_below else hinv_above, y, lo, hi, sx, sy)
    _weights_span(sx, sy, height, lo, hi, offset[y], weights[0, y], weights[1, y],
                  weights[2, y], weights[3, y], uncovered[y])


@njit(**JIT)
def _source_span(hinv, y, lo, hi, sx, sy):
    """Where pixels lo..hi-1 of row y come from (previous frame's pixel coordinates)."""
    c0 = hinv[0, 1] * y + hinv[0, 2]
    c1 = hinv[1, 1] * y + hinv[1, 2]
    c2 = hinv[2, 1] * y + hinv[2, 2]
    for x in range(lo, hi):
        den = hinv[2, 0] * x + c2
        inv = 1.0 / max(den, 1e-12)  # den <= 0: behind the camera, outside below
        sx[x] = (hinv[0, 0] * x + c0) * inv if den > 1e-12 else -1.0
        sy[x] = (hinv[1, 0] * x + c1) * inv


@njit(**JIT)
def _weights_span(sx, sy, height, lo, hi, off, w00, w01, w10, w11, unc):
    """Source cells and bilinear weights of a span from its source coordinates."""
    width = off.shape[0]
    wm1, hm1 = width - 1.0, height - 1.0
    xmax, ymax = np.int32(max(width - 2, 0)), np.int32(max(height - 2, 0))
    stride = np.int32(width + 1)
    one, zero = np.float32(1.0), np.float32(0.0)
    for x in range(lo, hi):
        ok = (sx[x] >= 0.0) & (sx[x] <= wm1) & (sy[x] >= 0.0) & (sy[x] <= hm1)
        cx = min(max(sx[x], 0.0), wm1)  # a safe cell where uncovered
        cy = min(max(sy[x], 0.0), hm1)
        ix = min(np.int32(cx), xmax)
        iy = min(np.int32(cy), ymax)
        off[x] = iy * stride + ix
        ax = np.float32(cx - ix)
        ay = np.float32(cy - iy)
        on = one if ok else zero
        bx = one - ax
        by = one - ay
        w00[x] = on * bx * by
        w01[x] = on * ax * by
        w10[x] = on * bx * ay
        w11[x] = on * ax * ay
        unc[x] = one - on


@njit(**JIT)
def _uncovered_span(y, lo, hi, offset, weights, uncovered):
    for x in range(lo, hi):
        offset[y, x] = 0
        for k in range(4):
            weights[k, y, x] = 0.0
        uncovered[y, x] = 1.0


def apply_plan(plan: Plan, values: np.ndarray, fill: np.ndarray | None,
               scratch: np.ndarray, gain: np.ndarray | None = None) -> None:
    """Warp one (H, W) float32 map in place by `plan`, times `gain` (an (H, W) float32
    field, or None for 1); uncovered pixels take `fill` (an (H, W) float32 map) or 0 where
    `fill` is None. `scratch` is a zeroed
    (H + 1, W + 1) float32 buffer (its last row and column stay 0: a 1-pixel frame reads
    them with weight 0)."""
    height, width = values.shape
    scratch[:height, :width] = values
    _apply(plan.offset, plan.weights, plan.uncovered, scratch.reshape(-1), values,
           values if fill is None else fill, fill is not None,
           values if gain is None else gain, gain is not None)


@njit(**JIT)
def _apply(offset, weights, uncovered, src, dst, fill, use_fill, gain, use_gain):
    height, width = dst.shape
    below = width + 1  # the source's row stride
    w00, w01, w10, w11 = weights[0], weights[1], weights[2], weights[3]
    for y in range(height):
        off, a, b, c, d = offset[y], w00[y], w01[y], w10[y], w11[y]
        out = dst[y]
        for x in range(width):
            k = off[x]
            out[x] = (a[x] * src[k] + b[x] * src[k + 1] + c[x] * src[k + below]
                      + d[x] * src[k + below + 1])
        if use_gain:
            g = gain[y]
            for x in range(width):
                out[x] *= g[x]
        if use_fill:
            u, f = uncovered[y], fill[y]
            for x in range(width):
                out[x] += u[x] * f[x]


def fill_pad_columns(padded: np.ndarray, width: int, border: int) -> None:
    """Refill the one padding column each side of rows stored at ``padded[..., 1:width+1]``
    by a kernel border rule (`lgmd_sim.models.kernels.BORDERS`), after their values moved."""
    if border == ZERO:
        padded[..., 0] = 0.0
        padded[..., width + 1] = 0.0
        return
    reflect = border == REFLECT and width > 1
    padded[..., 0] = padded[..., 2 if reflect else 1]
    padded[..., width + 1] = padded[..., width - 1 if reflect else width]
