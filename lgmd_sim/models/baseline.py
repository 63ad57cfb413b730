"""What the published baselines share: LGMD1, LGMD2 and the F(ON)/F(OFF) LGMDs.

Their common parameters (`BaselineParams`: G layer, sigmoid, borders, luminance
persistence), the host-side helpers around their kernels (border rules, persistence
weights, the sigmoid potential, first frames) and the numba rows every baseline kernel
calls: P = L(t) - L(t-1) with or without persistence, the end of an S row, and the G
layer of Yue & Rind (2006). The models themselves are in `lgmd_sim.models.lgmd1`,
`lgmd_sim.models.lgmd2` and `lgmd_sim.models.ffi`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from lgmd_sim.core.params import non_negative, one_of, param, positive, tuple_of
from lgmd_sim.models.base import ModelParams
from lgmd_sim.models.kernels import BORDERS, JIT, REFLECT, TAP_FLOOR, fill_borders_as
from lgmd_sim.models.search import SearchRange
from lgmd_sim.models.sources import SOURCES

__all__ = [
    "BORDER_DOC",
    "BORDER_RULES",
    "NO_MAP",
    "PERSISTENCE",
    "BaselineParams",
    "boolean",
    "border_code",
    "diff_row",
    "finish_s_row",
    "g_row",
    "g_sum",
    "persist_row",
    "persistence_weights",
    "sigmoid_potential",
    "take_first_frames",
]

#: Stands in for the layer maps when none are asked for.
NO_MAP = np.empty((0, 0, 0), np.float32)

_PI, _SINGLE, _PLGMD = SOURCES["pi-lgmd"], SOURCES["lgmd-single"], SOURCES["plgmd"]
_ALL_G = f"{_PI}; {SOURCES['lgmd2']}; {SOURCES['olgmd']}"


def boolean(v: Any) -> str | None:
    """Check of a switch parameter: None if ``v`` is a bool, else what is wrong."""
    return None if isinstance(v, bool | np.bool_) else "must be True or False"


#: Values of the ``border`` parameter: the kernel rules, and "interior" (S is only computed
#: away from the frame's edge, zero on a 1-pixel border; the G layer's Ce reflects).
BORDER_RULES = (*BORDERS, "interior")
PERSISTENCE = ("none", "constant", "decaying")
#: The ``border`` parameter's doc, for a model that gives it another default.
BORDER_DOC = (
    "cells outside the frame in 3x3 neighbourhoods: 'replicate' the edge (C#), 'reflect' "
    "(OpenCV's default, BORDER_REFLECT_101), 'zero' (MATLAB conv2 'same'), or 'interior' "
    "(S zero on a 1-pixel border, Ce reflected)")


#: The baselines' calibration search (`LGMDModel.search_space`): the sigmoid's coefficient,
#: a scale over three decades (their threshold is searched as for every model).
SIGMOID_SEARCH = {"c_sig": SearchRange(0.1, 100.0)}


def border_code(border: str) -> tuple[int, bool]:
    """The kernels' border rule of a ``border`` parameter, and whether S is interior-only."""
    return (REFLECT, True) if border == "interior" else (BORDERS[border], False)


@dataclass(frozen=True)
class BaselineParams(ModelParams):
    """What LGMD1, LGMD2 and the F(ON)/F(OFF) LGMDs share: G layer, sigmoid, borders, P."""

    delta_c: float = param(0.01, _ALL_G, check=positive,
                           doc="Delta_c in the G layer's scale w = delta_c + max|Ce| / c_w")
    c_w: float = param(4.0, _ALL_G, check=positive, doc="C_w in w = delta_c + max|Ce| / c_w")
    c_de: float = param(0.5, _ALL_G + f" (0.15 in {_PLGMD})", check=positive,
                        doc="C_de: G is zeroed where G * c_de < t_de")
    t_de: float = param(15.0, _ALL_G, check=non_negative,
                        doc="T_de: G is zeroed where G * c_de < t_de")
    c_sig: float = param(1.0, f"{_PI}; {_SINGLE}; {_PLGMD}; {SOURCES['lgmd2']} (C_sig = 1)",
                         check=positive,
                         doc="C_sig: the potential is sigmoid(sum G / (n_cells * c_sig))")
    border: str = param("replicate", f"{SOURCES['lgmd2']}, {_SINGLE}: indices clamped",
                        check=one_of(*BORDER_RULES), doc=BORDER_DOC)
    persistence: str = param(
        "none", f"{_PI}, {_SINGLE}, {SOURCES['lgmd2']}: P(t) = L(t) - L(t-1)",
        check=one_of(*PERSISTENCE),
        doc="luminance persistence P(t) = L(t) - L(t-1) + c1 P(t-1) + c2 P(t-2): 'none' "
            "(c = 0), 'constant' (c = persistence_weights, pLGMD), 'decaying' (c_j = "
            "1 / (1 + exp(k + 1 - j)) at a stream's frame k = 0, 1, ..., the oLGMD)")
    persistence_weights: tuple[float, float] = param(
        (0.5, 0.5), f"{_PLGMD} (p1 = p2 = 1 / (1 + exp(0)))",
        check=tuple_of(non_negative, 2), doc="(c1, c2) of persistence 'constant'")


def _decaying_weights() -> np.ndarray:
    """(c1, c2) of 'decaying' persistence at a stream's frames k = 0, 1, ... while either
    is above `TAP_FLOOR` (smaller ones are 0: they could not change P by 2e-5 grey
    levels), then one row of zeros for every later frame."""
    k = np.arange(64, dtype=np.float64)[:, None] + 1.0 - np.array([1.0, 2.0])
    c = 1.0 / (1.0 + np.exp(k))
    c[c < TAP_FLOOR] = 0.0
    return c[: np.flatnonzero(c.any(axis=1))[-1] + 2].astype(np.float32)


_DECAYING = _decaying_weights()


def persistence_weights(
    mode: str, weights: tuple[float, float], frame_index: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per stream (c1, c2) float32 at each stream's frame index, and whether to run it.

    'decaying' weights only fall, so a stream whose weights are 0 needs its older P no
    more ("run" is False: the kernels skip that work).
    """
    n = len(frame_index)
    if mode == "none":
        return np.zeros((n, 2), np.float32), np.zeros(n, bool)
    if mode == "constant":
        return np.tile(np.asarray(weights, np.float32), (n, 1)), np.full(n, any(weights))
    c = _DECAYING[np.minimum(frame_index, len(_DECAYING) - 1)]
    return c, (c > 0).any(axis=1)


def sigmoid_potential(g_sum: np.ndarray, n_cells: int, c_sig: float) -> np.ndarray:
    """K = 1 / (1 + exp(-sum G / (n_cells c_sig))), kept below 1 (float64 rounds up past 37)."""
    k = 1.0 / (1.0 + np.exp(-np.asarray(g_sum, np.float64) / (n_cells * c_sig)))
    return np.minimum(k, np.nextafter(1.0, 0.0))


def take_first_frames(grey: np.ndarray, prev: np.ndarray, fresh: np.ndarray) -> np.ndarray:
    """Make the first frame of each fresh stream its own previous frame (so P = 0).

    ``prev`` is uint8 until a float frame comes; then it becomes float32 for good. Returns
    the (possibly new) ``prev`` array; clears ``fresh``.
    """
    if grey.dtype != np.uint8 and prev.dtype == np.uint8:
        prev = prev.astype(np.float32)
    if fresh.any():
        prev[fresh] = grey[fresh]
        fresh[:] = False
    return prev


# --- the G layer --------------------------------------------------------------------------

_NINTH = np.float32(1.0 / 9.0)


@njit(**JIT)
def g_row(s_above, s_row, s_below, vsum, q_row, ce_cols):
    """G layer, one row: q = S Ce with Ce the 3x3 mean of S (Yue & Rind 2006).

    S rows are padded (width + 2, borders filled); ``vsum`` is a width + 2 scratch line.
    ``ce_cols`` (width) keeps each column's max |Ce| so far, for w in `g_sum`: a running
    max over x would be a float reduction, which LLVM leaves scalar here (4x slower).
    """
    width = q_row.shape[0]
    for x in range(width + 2):
        vsum[x] = s_above[x] + s_row[x] + s_below[x]
    for x in range(width):
        ce = (vsum[x] + vsum[x + 1] + vsum[x + 2]) * _NINTH
        q_row[x] = s_row[x + 1] * ce
        ce_cols[x] = max(ce_cols[x], abs(ce))


@njit(**JIT)
def g_sum(q, ce_cols, delta_c, c_w, c_de, t_de, want, g_out):
    """Sum of G = q / w over the cells where G c_de >= t_de, w = delta_c + max|Ce| / c_w.

    ``ce_cols`` holds the max |Ce| of each column (`g_row`). With ``want``, ``g_out``
    (H, W) receives the G map. G is never negative where kept, so this is also sum |G|.
    """
    height, width = q.shape
    ce_max = ce_cols[0]
    for x in range(width):  # once a frame: scalar is fine
        ce_max = max(ce_max, ce_cols[x])
    w = delta_c + ce_max / c_w
    cut = np.float32(t_de * w / c_de)  # G c_de >= t_de  <=>  q >= t_de w / c_de
    inv_w = np.float32(1.0 / w)
    zero = np.float32(0.0)
    total = 0.0
    for y in range(height):
        row = q[y]
        if want:
            out = g_out[y]
            for x in range(width):
                out[x] = row[x] * inv_w if row[x] >= cut else zero
        acc = zero
        for x in range(width):
            acc += row[x] if row[x] >= cut else zero
        total += acc
    return total / w


# --- P and S rows -------------------------------------------------------------------------


@njit(**JIT)
def diff_row(fr, pr, out):
    """One row of P = L(t) - L(t-1)."""
    for x in range(out.shape[0]):
        out[x] = np.float32(fr[x]) - np.float32(pr[x])


@njit(**JIT)
def persist_row(fr, pr, p1, p2, c1, c2, out):
    """One row of P = L(t) - L(t-1) + c1 P(t-1) + c2 P(t-2) (luminance persistence)."""
    for x in range(out.shape[0]):
        out[x] = (np.float32(fr[x]) - np.float32(pr[x])) + (c1 * p1[x] + c2 * p2[x])


@njit(**JIT)
def finish_s_row(sr, y, height, width, interior, border):
    """Zero S on the frame's 1-pixel border (``interior``), then fill the row's padding."""
    zero = np.float32(0.0)
    if interior:
        if y == 0 or y == height - 1:
            sr[:] = zero
        else:
            sr[1] = zero
            sr[width] = zero
    fill_borders_as(sr, 1, width, border)
