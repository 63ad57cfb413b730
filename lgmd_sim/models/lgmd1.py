"""LGMD1: the classic LGMD of Yue & Rind (2006) with the G layer and feed-forward inhibition.

Layers, per frame t (grey levels 0..255), with the switches that tell the published
implementations apart (docs/reference/models.md, "Baselines"):

- P = L(t) - L(t-1) (0 on the first frame of a stream), plus ``persistence`` of the last
  two P (pLGMD); E = P.
- I = E(t-1) convolved with the 3x3 kernel (``inhibition_near`` at the 4 neighbours,
  ``inhibition_diagonal`` at the diagonals, 0 at the centre): one frame of delay.
- S = E - w_i I; optionally zeroed where S < t_s (``t_s_rule``: S or |S|) and
  (``coincidence``) where E I <= 0.
- ``g_layer``: G = S Ce / w with Ce the 3x3 mean of S and w = delta_c + max|Ce| / c_w,
  zeroed where G c_de < t_de; K = sigmoid(sum|G| / (n_cells c_sig)). Without it (as in
  LGMDSingle.cs) K = sigmoid(sum S / (n_cells c_sig)).
- K is set to its resting value 0.5 while the feed-forward inhibition (mean |P(t-1)| >=
  t_ffi) is on. K is the reported potential.
- ``border``: how 3x3 neighbourhoods read outside the frame.

Presets: ``published`` (the default) is XuelongSun/InsectInspiredNavigation_PI-LGMD's
model; ``lgmd-single`` and ``plgmd`` are the other two published implementations,
``v0.1`` this project's first reading. What LGMD2 and the F(ON) / F(OFF) LGMDs share with
it (the G layer, the sigmoid, border rules and luminance persistence) is in
`lgmd_sim.models.baseline`. `lgmd_sim.models.reference.baselines` has the per-equation
float64 version this one is tested against, `lgmd_sim.models.reference.published` ports
of the published code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from lgmd_sim.core.params import because, non_negative, one_of, optional, param, positive
from lgmd_sim.models.base import LGMDModel, ModelParams, StateMap
from lgmd_sim.models.baseline import (
    BORDER_DOC,
    BORDER_RULES,
    NO_MAP,
    SIGMOID_SEARCH,
    BaselineParams,
    boolean,
    border_code,
    diff_row,
    finish_s_row,
    g_row,
    g_sum,
    persist_row,
    persistence_weights,
    sigmoid_potential,
    take_first_frames,
)
from lgmd_sim.models.kernels import JIT, fill_borders_as, row_index, staggered_arrays
from lgmd_sim.models.search import SearchRange
from lgmd_sim.models.sources import SOURCES

__all__ = ["LGMD1", "LGMD1Params"]

_PI, _SINGLE, _PLGMD = SOURCES["pi-lgmd"], SOURCES["lgmd-single"], SOURCES["plgmd"]


@dataclass(frozen=True)
class LGMD1Params(BaselineParams):
    """Parameters of LGMD1; defaults: the PI-LGMD model (preset ``published``)."""

    w_i: float = param(0.4, f"{_PI} (i_w; 0.6 in {_SINGLE}, 0.3 in {_PLGMD})",
                       check=non_negative, doc="W_I: weight of the inhibition in S = E - W_I I")
    inhibition_near: float = param(0.25, f"{_PI}; {_SINGLE}; {_PLGMD}", check=non_negative,
                                   doc="inhibition kernel weight of the 4 nearest neighbours")
    inhibition_diagonal: float = param(0.125, f"{_PI}; {_SINGLE}; {_PLGMD}",
                                       check=non_negative,
                                       doc="inhibition kernel weight of the 4 diagonal "
                                           "neighbours")
    t_s: float | None = param(None, f"{_PI}, {_PLGMD}: no threshold (Ts = 30 in {_SINGLE})",
                              check=optional(non_negative),
                              doc="S threshold T_s (see t_s_rule); None: none")
    t_s_rule: str = param("signed", f"{_SINGLE} (scellValue keeps E - I W_i >= Ts)",
                          check=one_of("signed", "abs"),
                          doc="'signed': S is zeroed where S < t_s (so every S < t_s, "
                              "darkening included, is dropped); 'abs': where |S| < t_s")
    coincidence: bool = param(False, f"{_PI}, {_PLGMD}: none (True in {_SINGLE}, which "
                              "zeroes S where E * I <= 0)", check=boolean,
                              doc="zero S where E * I <= 0: excitation passes only next to "
                                  "same-sign excitation of the previous frame")
    t_ffi: float | None = param(
        None, f"{_PI}: its FFI gates spikes only, never K; {_PLGMD}: none (10 in {_SINGLE})",
        check=optional(because(positive, "at 0 the FFI holds the potential at 0.5 on every "
                                         "frame; None turns it off")),
        doc="feed-forward inhibition: the potential rests at 0.5 while mean |P(t-1)| >= "
            "t_ffi; None: no FFI")
    g_layer: bool = param(True, f"{_PI}; {_PLGMD} (none in {_SINGLE}: K from sum S)",
                          check=boolean,
                          doc="the G layer; without it K = sigmoid(sum S / (n_cells c_sig))")
    border: str = param("reflect", f"{_PI} (cv2.filter2D's default border)",
                        check=one_of(*BORDER_RULES), doc=BORDER_DOC)


#: A t_s that keeps every S (t_s = None), finite: the kernels assume no infinities.
NO_THRESHOLD = np.float32(np.finfo(np.float32).min)


# --- LGMD1 --------------------------------------------------------------------------------


@njit(**JIT)
def _lgmd1_frames(frames, prev, e_prev, p_older, persist_w, persist_on, w_i, k_near, k_diag,
                  t_s, ts_sign, coincidence, g_layer, border, interior, delta_c, c_w, c_de,
                  t_de, s_ring, p_ring, vsum, q, ce_cols, want, l_p, l_s, l_g, g_total,
                  abs_p_total):
    """One frame per stream; E(t-1) in ``e_prev`` (rows padded by a column each side, and
    a row of zeros after the last) is replaced by E(t) = P(t), and P(t-2) in ``p_older``
    by P(t-1) where persistence runs. ``s_ring`` holds 3 rows of S and a zero row.

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
        persist = persist_on[n]
        c1 = persist_w[n, 0]
        c2 = persist_w[n, 1]
        ce_cols[:] = zero
        abs_p = 0.0
        s_total = 0.0
        for y in range(height + 1):
            if y < height:
                fr = frame[y]
                pr = pv[y]
                pl = p_ring[y % 2]
                b = e[y]  # E(t-1) = P(t-1) of rows y-1, y, y+1
                a = e[row_index(y - 1, height, height, border)]
                c = e[row_index(y + 1, height, height, border)]
                if persist:
                    persist_row(fr, pr, b[1:width + 1], p_older[n, y], c1, c2, pl)
                else:
                    diff_row(fr, pr, pl)
                for x in range(width):
                    pr[x] = fr[x]
                sr = s_ring[y % 3]
                for x in range(width):
                    p = pl[x]  # = E
                    inh = k_near * (a[x + 1] + c[x + 1] + b[x] + b[x + 2]) + k_diag * (
                        a[x] + a[x + 2] + c[x] + c[x + 2])  # I = E(t-1) * w_I
                    s = p - w_i * inh  # S = E - W_I I
                    # ts_sign -1 compares |S| with t_s, +1 S itself
                    keep = (max(s, ts_sign * s) >= t_s) & ((p * inh > zero) | use_all)
                    sr[x + 1] = s if keep else zero
                finish_s_row(sr, y, height, width, interior, border)
                acc = zero
                for x in range(width):
                    acc += abs(pl[x])
                abs_p += acc
                if not g_layer:
                    acc = zero
                    for x in range(width):
                        acc += sr[x + 1]
                    s_total += acc
                if want:
                    l_p[n, y] = pl
                    l_s[n, y] = sr[1:width + 1]
            if y >= 1:
                er = e[y - 1]  # E(t) of row y-1: its old value is no longer read
                if persist:
                    p_older[n, y - 1] = er[1:width + 1]
                er[1:width + 1] = p_ring[(y - 1) % 2]
                fill_borders_as(er, 1, width, border)
                if g_layer:
                    g_row(s_ring[row_index(y - 2, 3, height, border)], s_ring[(y - 1) % 3],
                          s_ring[row_index(y, 3, height, border)], vsum, q[y - 1], ce_cols)
        if g_layer:
            g_total[n] = g_sum(q, ce_cols, delta_c, c_w, c_de, t_de, want,
                               l_g[n] if want else q)  # q: a typed stand-in, not written
        else:
            g_total[n] = s_total
            if want:
                l_g[n] = zero
        abs_p_total[n] = abs_p


class LGMD1(LGMDModel):
    """LGMD1 (Yue & Rind 2006): excitation, one-frame-delayed lateral inhibition, G layer, FFI.

    The reported potential is K, the sigmoid membrane potential, held at its resting value
    0.5 while the feed-forward inhibition is on. The published spike and collision outputs
    are not modelled: the project's metrics work on K.
    """

    name: ClassVar[str] = "lgmd1"
    Params: ClassVar[type[ModelParams]] = LGMD1Params
    layer_names: ClassVar[tuple[str, ...]] = ("P", "S", "G")
    presets: ClassVar[dict[str, dict[str, Any]]] = {
        "published": {},  # PI-LGMD's LobulaGiantMotionDetectorModel.run
        "lgmd-single": {"w_i": 0.6, "t_s": 30.0, "t_s_rule": "signed", "coincidence": True,
                        "t_ffi": 10.0, "g_layer": False, "border": "replicate"},
        "plgmd": {"w_i": 0.3, "c_de": 0.15, "persistence": "constant", "border": "zero"},
        # this project's first reading: LGMDSingle.cs with the G layer and |S| >= Ts
        "v0.1": {"w_i": 0.6, "t_s": 30.0, "t_s_rule": "abs", "coincidence": True,
                 "t_ffi": 10.0, "border": "replicate"},
    }
    search_space: ClassVar[dict[str, SearchRange]] = SIGMOID_SEARCH

    params: LGMD1Params

    def allocate(self, n: int, height: int, width: int) -> None:
        # The previous frame stays uint8 (less memory traffic) until a float frame comes.
        self._prev = np.zeros((n, height, width), np.uint8)
        self._fresh = np.ones(n, bool)
        self._mean_abs_p = np.zeros(n)
        self._frame_index = np.zeros(n, np.int64)
        older = (n, height, width) if self.params.persistence != "none" else (1, 1, 1)
        # Staggered (`staggered_arrays`): allocated apart, some instances ran 2.5x slower.
        self._e, self._p_older, self._s_ring, self._p_ring, self._vsum, self._q, self._ce_cols = (
            staggered_arrays([(n, height + 1, width + 2), older, (4, width + 2), (2, width),
                              (width + 2,), (height, width), (width,)]))

    def reset_streams(self, idx: np.ndarray) -> None:
        self._e[idx] = 0.0
        if self._p_older.shape[0] == self._n:
            self._p_older[idx] = 0.0
        self._mean_abs_p[idx] = 0.0
        self._frame_index[idx] = 0
        self._fresh[idx] = True

    def state_maps(self) -> list[StateMap]:
        # E(t-1) = P(t-1) in padded rows; P(t-2) where persistence keeps it
        maps = [StateMap("_prev", "frame"),
                StateMap("_e", padded=border_code(self.params.border)[0])]
        return maps + ([StateMap("_p_older")] if self.params.persistence != "none" else [])

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        self._prev = take_first_frames(grey, self._prev, self._fresh)
        p = self.params
        f32 = np.float32
        n, height, width = grey.shape
        border, interior = border_code(p.border)
        weights, persist = persistence_weights(p.persistence, p.persistence_weights,
                                               self._frame_index)
        maps = [layers[k] for k in self.layer_names] if layers else [NO_MAP] * 3
        g_total = np.empty(n)
        abs_p = np.empty(n)
        _lgmd1_frames(
            grey, self._prev, self._e, self._p_older, weights, persist, f32(p.w_i),
            f32(p.inhibition_near), f32(p.inhibition_diagonal),
            NO_THRESHOLD if p.t_s is None else f32(p.t_s),
            f32(1.0 if p.t_s_rule == "signed" else -1.0), bool(p.coincidence),
            bool(p.g_layer), border, interior, p.delta_c, p.c_w, p.c_de, p.t_de,
            self._s_ring, self._p_ring, self._vsum, self._q, self._ce_cols,
            layers is not None, *maps, g_total, abs_p,
        )
        self._frame_index += 1
        potential = sigmoid_potential(g_total, height * width, p.c_sig)
        if p.t_ffi is not None:
            potential[self._mean_abs_p >= p.t_ffi] = 0.5  # FFI from mean |P(t-1)|
        self._mean_abs_p = abs_p / (height * width)
        return potential

