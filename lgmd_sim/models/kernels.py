"""Numba primitives shared by the fast LGMD models: row-pipelined separable filtering.

A fast model processes a frame in one pass over memory, row by row: for row ``y`` it
computes the per-pixel layers into small line buffers (which stay in L1 cache), filters
them horizontally (`hconv`) into a ring of ``2R + 1`` rows, and finishes row ``y - R``
by filtering that ring vertically (`vconv`).
Whole-frame intermediates never reach memory; only the state a model keeps between
frames does. `fill_borders`, `ring_slot` and `vconv` replicate borders (OpenCV's
``BORDER_REPLICATE``); `fill_borders_as` and `border_row` apply any of the rules in
`BORDERS` (the published baselines differ in it).

Conventions: rows are 1-D float32 arrays, and every loop over x runs over 1-D row views
(indexing a 3-D or 4-D array inside such a loop stops LLVM from vectorising it: 4x
slower). A filter is a tuple of float32 taps of odd length (radius ``len(taps) // 2``):
numba compiles one version per length, so loops over taps unroll and loops over x,
contiguous and branch-free, vectorise. Keep float32 constants (``np.float32(...)``) in
such loops: a float64 literal forces float64 maths.

These functions are part of the models' contract: keep their signatures and semantics.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from lgmd_sim.core.params import checked, positive

__all__ = [
    "BORDERS",
    "JIT",
    "REFLECT",
    "REPLICATE",
    "TAP_FLOOR",
    "ZERO",
    "border_row",
    "fill_borders",
    "fill_borders_as",
    "gaussian_taps",
    "hconv",
    "ordered_sum",
    "ring_slot",
    "row_index",
    "staggered_arrays",
    "vconv",
]

#: Options of every model kernel: compiled once per signature and cached on disk, GIL
#: released so that threads can run streams side by side, and no fast-maths that reorders
#: or fuses arithmetic (reassociation, contraction into fused multiply-adds, reciprocals,
#: approximate functions): a loop LLVM vectorises falls back to scalar code when its runtime
#: alias check fails, which depends on where the arrays lie, and the two paths then round
#: differently; so did the code compiled for two processors, and a kernel compiled afresh
#: and its cached copy (measured: the demo's LoomSteer episode, lgmd1's kernel, parted at
#: frame 7). Without them every path computes the same operations in the same order: a
#: stream gets the same bits in any batch, on any processor, compiled or cached
#: (`lgmd_sim.core.numerics`). It costs lgmd1 about half its frames per second, lgmd2, F(ONn)
#: and F(OFFp) about a third (docs/experiments/replay.md). nnan, ninf: inputs are checked
#: finite before they get here.
JIT = {"cache": True, "fastmath": {"nnan", "ninf", "nsz"}, "nogil": True}

#: Relative size below which a filter tap is dropped: float32's unit roundoff, 2^-24.
TAP_FLOOR = 2.0**-24

#: Border rules for cells outside the frame, as kernel arguments: replicate the edge cell
#: (OpenCV's BORDER_REPLICATE; a clamped index), reflect about it without repeating it
#: (BORDER_REFLECT_101, OpenCV's default: column -1 is column 1), or read zeros (MATLAB's
#: conv2 'same').
REPLICATE, REFLECT, ZERO = 0, 1, 2
#: The rules by name, as parameters give them.
BORDERS = {"replicate": REPLICATE, "reflect": REFLECT, "zero": ZERO}


def gaussian_taps(sigma: float) -> tuple[np.float32, ...]:
    """Taps of a sampled, normalised 1-D Gaussian of standard deviation ``sigma`` (pixels).

    The radius is ``max(1, ceil(3 sigma))``. Outer taps below `TAP_FLOOR` times the
    centre tap are then dropped: in float32 they cannot change a sum that has a centre
    term (they are under its rounding error), and kept they make denormal products,
    which x86 computes about 100 times slower (sigma = 0.1 has outer taps of 2e-22, whose
    square times a grey level is below 1e-38). So a sigma below about 0.18 pixels leaves
    the single tap 1.0, the identity that float32 would compute anyway; sigma = 0.3 keeps
    3 taps (0.0038, 0.9923, 0.0038). The 2-D filter of Eq. 9 is the outer product of the
    taps with themselves.
    """
    checked("Gaussian sigma", sigma, positive)
    r = max(1, math.ceil(3.0 * sigma))
    x = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-(x * x) / (2.0 * sigma * sigma))
    keep = int(np.count_nonzero(g[:r] >= TAP_FLOOR))  # outer taps kept on each side
    g = g[r - keep : r + keep + 1]
    return tuple(np.float32(v) for v in g / g.sum())


def staggered_arrays(shapes: list[tuple[int, ...]]) -> list[np.ndarray]:
    """Zeroed C-contiguous float32 arrays of these shapes, in one block, staggered.

    A kernel streams the same row of several state arrays at once. Allocated apart, such
    arrays often start at the same offset within a 4 KiB page, so those rows compete for
    the same L1 cache sets (and loads alias earlier stores to the same page offset); the
    speed then varied by a third from one model instance to the next. Here array k starts
    at byte offset 448 k (7 cache lines) modulo 4096.
    """
    sizes = [math.prod(shape) for shape in shapes]
    block = np.zeros(sum(sizes) + _PAGE_FLOATS * (len(sizes) + 1), np.float32)
    start = block.ctypes.data // 4
    pos = 0
    out = []
    for k, (shape, size) in enumerate(zip(shapes, sizes, strict=True)):
        pos += (k * _STAGGER_FLOATS - (start + pos)) % _PAGE_FLOATS
        out.append(block[pos : pos + size].reshape(shape))
        pos += size
    return out


_PAGE_FLOATS = 1024  # 4 KiB
_STAGGER_FLOATS = 112  # 448 bytes


@njit(**JIT)
def fill_borders(padded: np.ndarray, r: int, width: int) -> None:
    """Replicate the end values of ``padded[r:r + width]`` into its ``r`` cells each side."""
    first = padded[r]
    last = padded[r + width - 1]
    for i in range(r):
        padded[i] = first
        padded[r + width + i] = last


@njit(**JIT)
def fill_borders_as(padded: np.ndarray, r: int, width: int, border: int) -> None:
    """Fill the ``r`` cells each side of ``padded[r:r + width]`` by a border rule."""
    zero = np.float32(0.0)
    for i in range(r):
        left = padded[r + border_row(-1 - i, width, border)] if border != ZERO else zero
        right = padded[r + border_row(width + i, width, border)] if border != ZERO else zero
        padded[r - 1 - i] = left
        padded[r + width + i] = right


@njit(**JIT)
def border_row(row: int, height: int, border: int) -> int:
    """The row (or column) inside 0..height-1 that stands for ``row`` under a border rule.

    -1 for a cell outside the frame under `ZERO` (the caller reads zeros there).
    """
    if 0 <= row < height:
        return row
    if border == ZERO:
        return -1
    if border == REFLECT:
        row = -row if row < 0 else 2 * (height - 1) - row
    return min(max(row, 0), height - 1)


@njit(**JIT)
def row_index(row: int, n_rows: int, height: int, border: int) -> int:
    """Where image row ``row`` of a frame of ``height`` rows is, under a border rule, in
    an array of ``n_rows + 1`` rows: row i at ``i % n_rows`` (the whole frame, or a ring
    holding the rows near ``row``), and zeros at ``n_rows`` for a cell outside the frame
    under `ZERO`. (An index, not a row: a function returning an array view costs a
    reference count update per call.)
    """
    r = border_row(row, height, border)
    return r % n_rows if r >= 0 else n_rows


@njit(**JIT)
def hconv(padded: np.ndarray, taps: tuple, out: np.ndarray) -> None:
    """Horizontal filter: ``out[x] = sum_k taps[k] * padded[x + k]`` for x < len(out).

    ``padded`` holds the row at offset ``len(taps) // 2`` with its borders filled
    (`fill_borders`).
    """
    for x in range(out.shape[0]):
        acc = np.float32(0.0)
        for k in range(len(taps)):
            acc += taps[k] * padded[x + k]
        out[x] = acc


@njit(cache=True, nogil=True)  # no fastmath: the order of the additions must not change
def ordered_sum(values: np.ndarray) -> float:
    """Sum of a 1-D array, left to right: the same bits wherever it is called from.

    For the last step of a reduction (e.g. of per-column sums): a fast-math sum inside a
    kernel is reordered by the vectoriser, differently in differently compiled loops.
    """
    total = 0.0
    for v in values:
        total += v
    return total


@njit(**JIT)
def ring_slot(row: int, height: int, n_slots: int) -> int:
    """Ring slot of image row ``row`` clamped to 0..height-1 (a replicated border)."""
    return min(max(row, 0), height - 1) % n_slots


@njit(**JIT)
def vconv(ring: np.ndarray, y: int, height: int, taps: tuple, out: np.ndarray) -> None:
    """Vertical filter at row ``y``: ``out = sum_k taps[k] * row(y - r + k)``.

    Image row ``i`` lives in ``ring[i % len(ring)]``; rows outside 0..height-1 are
    clamped. The ring must hold the rows ``y - r .. y + r`` (clamped).
    """
    n_slots = ring.shape[0]
    n = len(taps)
    r = n // 2
    if n == 3:  # the common case in one loop
        a = ring[ring_slot(y - 1, height, n_slots)]
        b = ring[ring_slot(y, height, n_slots)]
        c = ring[ring_slot(y + 1, height, n_slots)]
        t0, t1, t2 = taps[0], taps[1], taps[2]
        for x in range(out.shape[0]):
            out[x] = t0 * a[x] + t1 * b[x] + t2 * c[x]
        return
    src = ring[ring_slot(y - r, height, n_slots)]
    t = taps[0]
    for x in range(out.shape[0]):
        out[x] = t * src[x]
    for k in range(1, n):
        src = ring[ring_slot(y - r + k, height, n_slots)]
        t = taps[k]
        for x in range(out.shape[0]):
            out[x] += t * src[x]
