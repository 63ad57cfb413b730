"""LGMD1: the classic LGMD of Yue & Rind (2006) with the G layer and feed-forward inhibition.

Layers, per frame t (grey levels 0..255), as the group's published code does them
(docs/models.md, "Baselines"):

- P = L(t) - L(t-1), 0 on the first frame of a stream; E = P.
- I = E(t-1) convolved with the 3x3 kernel (``inhibition_near`` at the 4 neighbours,
  ``inhibition_diagonal`` at the diagonals, 0 at the centre): one frame of delay.
- S = E - w_i I, zeroed where |S| < t_s and (``coincidence``) where E I <= 0.
- G = S Ce / w with Ce the 3x3 mean of S and w = delta_c + max|Ce| / c_w, zeroed where
  G c_de < t_de.
- K = 1 / (1 + exp(-sum|G| / (n_cells c_sig))), set to its resting value 0.5 while the
  feed-forward inhibition (mean |P(t-1)| >= t_ffi) is on. K is the reported potential.

This module also holds the G layer and the sigmoid shared by LGMD2 and the F(ON)/F(OFF)
LGMDs. `lgmd_sim.models.reference.baselines` has the per-equation float64 version this
one is tested against.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from lgmd_sim.models.base import LGMDModel, ModelParams
from lgmd_sim.models.kernels import JIT as _JIT
from lgmd_sim.models.kernels import fill_borders, ring_slot, staggered_arrays
from lgmd_sim.params import non_negative, param, positive

#: The shared kernel options without fused multiply-add contraction: a loop LLVM vectorises
#: falls back to scalar code when its runtime alias check fails, which depends on where
#: the arrays lie; with contraction the two paths round differently, and a batched stream
#: would then differ from a lone one. Sums are taken in read-only loops (no alias check,
#: so always the same path and order) for the same reason.
JIT = {**_JIT, "fastmath": {"nnan", "ninf", "nsz", "arcp", "afn", "reassoc"}}

__all__ = ["LGMD1", "GLayerParams", "LGMD1Params", "sigmoid_potential"]

#: Stands in for the layer maps when none are asked for.
_NO_MAP = np.empty((0, 0, 0), np.float32)

_G_SOURCE = (
    "Yue & Rind 2006 G layer, as in fuqinbing/pLGMD LGMD.m and "
    "XuelongSun/InsectInspiredNavigation_PI-LGMD simulations/models.py (same value in "
    "fuqinbing/LGMD2-open-source lgmd2OpenSource.cs and Ryannnice/"
    "Supplementary_Materials_FFI_ON_OFF optimized_LGMD.py)"
)


def _boolean(v: Any) -> str | None:
    return None if isinstance(v, bool | np.bool_) else "must be True or False"


@dataclass(frozen=True)
class GLayerParams(ModelParams):
    """The G layer and the sigmoid, common to LGMD1, LGMD2 and the F(ON)/F(OFF) LGMDs."""

    delta_c: float = param(0.01, _G_SOURCE, check=positive,
                           doc="Delta_c in the G layer's scale w = delta_c + max|Ce| / c_w")
    c_w: float = param(4.0, _G_SOURCE, check=positive,
                       doc="C_w in w = delta_c + max|Ce| / c_w")
    c_de: float = param(0.5, _G_SOURCE, check=positive,
                        doc="C_de: G is zeroed where G * c_de < t_de")
    t_de: float = param(15.0, _G_SOURCE, check=non_negative,
                        doc="T_de: G is zeroed where G * c_de < t_de")
    c_sig: float = param(
        1.0, "LGMDSingle.cs, PI-LGMD models.py, pLGMD LGMD.m; lgmd2OpenSource.cs (Csig = 1)",
        check=positive, doc="C_sig: the potential is sigmoid(sum G / (n_cells * c_sig))")


@dataclass(frozen=True)
class LGMD1Params(GLayerParams):
    """Parameters of LGMD1; defaults from the group's published code (baselines.md)."""

    w_i: float = param(0.6, "fuqinbing/LGMD-Plus-and-GAs-Open-Source LGMDSingle.cs "
                       "(0.4 in PI-LGMD models.py, 0.3 in pLGMD LGMD.m)", check=non_negative,
                       doc="W_I: weight of the inhibition in S = E - W_I I")
    inhibition_near: float = param(0.25, "LGMDSingle.cs; PI-LGMD models.py; pLGMD LGMD.m",
                                   check=non_negative,
                                   doc="inhibition kernel weight of the 4 nearest neighbours")
    inhibition_diagonal: float = param(0.125, "LGMDSingle.cs; PI-LGMD models.py; pLGMD LGMD.m",
                                       check=non_negative,
                                       doc="inhibition kernel weight of the 4 diagonal neighbours")
    t_s: float = param(30.0, "LGMDSingle.cs (Ts)", check=non_negative,
                       doc="S is zeroed where |S| < t_s (ours: |S|, since S is signed)")
    coincidence: bool = param(
        True, "LGMDSingle.cs (zeroes S where E * I <= 0)", check=_boolean,
        doc="zero S where E * I <= 0: excitation passes only next to same-sign excitation "
            "of the previous frame")
    t_ffi: float = param(10.0, "LGMDSingle.cs; PI-LGMD models.py; pLGMD LGMD.m (T_FFI)",
                         check=non_negative,
                         doc="feed-forward inhibition: the potential rests at 0.5 while "
                             "mean |P(t-1)| >= t_ffi")


def sigmoid_potential(g_sum: np.ndarray, n_cells: int, c_sig: float) -> np.ndarray:
    """K = 1 / (1 + exp(-sum G / (n_cells c_sig))), kept below 1 (float64 rounds up past 37)."""
    k = 1.0 / (1.0 + np.exp(-np.asarray(g_sum, np.float64) / (n_cells * c_sig)))
    return np.minimum(k, np.nextafter(1.0, 0.0))


# --- the G layer (shared) -----------------------------------------------------------------

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


# --- LGMD1 --------------------------------------------------------------------------------


@njit(**JIT)
def _lgmd1_frames(frames, prev, e_prev, w_i, k_near, k_diag, t_s, coincidence,
                  delta_c, c_w, c_de, t_de, s_ring, p_ring, vsum, q, ce_cols,
                  want, l_p, l_s, l_g, g_total, abs_p_total):
    """One frame per stream; E(t-1) in ``e_prev`` (padded) is replaced by E(t) = P(t).

    Row pipeline: S of row y needs E(t-1) of rows y-1..y+1, so E(t) of row y-1 is written
    back one row late; G of row y-1 follows once S of row y is in the ring.
    """
    n_streams, height, width = frames.shape
    zero = np.float32(0.0)
    use_all = not coincidence
    for n in range(n_streams):
        frame = frames[n]
        pv = prev[n]
        e = e_prev[n]
        ce_cols[:] = zero
        abs_p = 0.0
        for y in range(height + 1):
            if y < height:
                fr = frame[y]
                pr = pv[y]
                pl = p_ring[y % 2]
                a = e[y]  # E(t-1) rows y-1, y, y+1 (padded rows y, y+1, y+2)
                b = e[y + 1]
                c = e[y + 2]
                sr = s_ring[y % 3]
                for x in range(width):
                    p = np.float32(fr[x]) - np.float32(pr[x])  # P = E
                    pr[x] = fr[x]
                    pl[x] = p
                    inh = k_near * (a[x + 1] + c[x + 1] + b[x] + b[x + 2]) + k_diag * (
                        a[x] + a[x + 2] + c[x] + c[x + 2])  # I = E(t-1) * w_I
                    s = p - w_i * inh  # S = E - W_I I
                    keep = (abs(s) >= t_s) & ((p * inh > zero) | use_all)
                    sr[x + 1] = s if keep else zero
                fill_borders(sr, 1, width)
                acc = zero
                for x in range(width):
                    acc += abs(pl[x])
                abs_p += acc
                if want:
                    l_p[n, y] = pl
                    l_s[n, y] = sr[1:width + 1]
            if y >= 1:
                er = e[y]  # E(t) of row y-1: its old value is no longer read
                er[1:width + 1] = p_ring[(y - 1) % 2]
                fill_borders(er, 1, width)
                g_row(s_ring[ring_slot(y - 2, height, 3)], s_ring[(y - 1) % 3],
                      s_ring[ring_slot(y, height, 3)], vsum, q[y - 1], ce_cols)
        e[0] = e[1]  # replicated top and bottom borders
        e[height + 1] = e[height]
        g_total[n] = g_sum(q, ce_cols, delta_c, c_w, c_de, t_de, want,
                           l_g[n] if want else q)  # q: a typed stand-in, not written
        abs_p_total[n] = abs_p


class LGMD1(LGMDModel):
    """LGMD1 (Yue & Rind 2006): excitation, one-frame-delayed lateral inhibition, G layer, FFI.

    The reported potential is K, the sigmoid membrane potential, held at its resting value
    0.5 while the feed-forward inhibition is on. The published spike and collision outputs
    (K >= 0.78, 5 frames in a row) are not modelled: the project's metrics work on K.
    """

    name: ClassVar[str] = "lgmd1"
    Params: ClassVar[type[ModelParams]] = LGMD1Params
    layer_names: ClassVar[tuple[str, ...]] = ("P", "S", "G")
    presets: ClassVar[dict[str, dict[str, Any]]] = {"published": {}}

    params: LGMD1Params

    def _allocate(self, n: int, height: int, width: int) -> None:
        # The previous frame stays uint8 (less memory traffic) until a float frame comes.
        self._prev = np.zeros((n, height, width), np.uint8)
        self._fresh = np.ones(n, bool)
        self._mean_abs_p = np.zeros(n)
        # Staggered (`staggered_arrays`): allocated apart, some instances ran 2.5x slower.
        self._e, self._s_ring, self._p_ring, self._vsum, self._q, self._ce_cols = (
            staggered_arrays([(n, height + 2, width + 2), (3, width + 2), (2, width),
                              (width + 2,), (height, width), (width,)]))

    def _reset_streams(self, idx: np.ndarray) -> None:
        self._e[idx] = 0.0
        self._mean_abs_p[idx] = 0.0
        self._fresh[idx] = True

    def _step(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        self._prev = take_first_frames(grey, self._prev, self._fresh)
        p = self.params
        f32 = np.float32
        n, height, width = grey.shape
        maps = [layers[k] for k in self.layer_names] if layers else [_NO_MAP] * 3
        g_total = np.empty(n)
        abs_p = np.empty(n)
        _lgmd1_frames(
            grey, self._prev, self._e, f32(p.w_i), f32(p.inhibition_near),
            f32(p.inhibition_diagonal), f32(p.t_s), bool(p.coincidence), p.delta_c, p.c_w,
            p.c_de, p.t_de, self._s_ring, self._p_ring, self._vsum, self._q, self._ce_cols,
            layers is not None, *maps, g_total, abs_p,
        )
        potential = sigmoid_potential(g_total, height * width, p.c_sig)
        potential[self._mean_abs_p >= p.t_ffi] = 0.5  # FFI from mean |P(t-1)|
        self._mean_abs_p = abs_p / (height * width)
        return potential


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
