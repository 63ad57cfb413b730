"""LGMD2 (Fu, Hu, Peng, Yue 2018/2019): ON/OFF channels, adaptive delayed inhibition, SFA.

Layers, per frame t (grey levels 0..255), as lgmd2OpenSource.cs does them (docs/models.md,
"Baselines"):

- P = L(t) - L(t-1), 0 on the first frame of a stream; PM = mean |P| low-passed with
  ``tau_pm``; W_on = max(w_on_min, PM / t_pm), W_off = max(w_off_min, PM / t_pm).
- ON = [P]+ + carry ON(t-1), OFF = [-P]+ + carry OFF(t-1).
- Delayed inhibition: each channel feeds three first-order low-passes (the centre, near
  and diagonal delays; coefficient dt / (dt + tau)); I = the 3x3 sum of the low-passes
  of the previous frames weighted by the centre / near / diagonal weights.
- S_on = [ON - W_on I_on]+, S_off = [OFF - W_off I_off]+, S = S_on + S_off + S_on S_off.
- G layer and sigmoid as in LGMD1 (`lgmd_sim.models.lgmd1`), over sum G.
- Spike-frequency adaptation (SFA) of the sigmoid output K: the reported potential.

`LGMD2` also serves the F(ON)/F(OFF) LGMDs (`lgmd_sim.models.ffi`), which add a
polarity-specific gate through the `_gates` hook.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from lgmd_sim.models.base import LGMDModel, ModelParams
from lgmd_sim.models.kernels import fill_borders, ring_slot, staggered_arrays
from lgmd_sim.models.lgmd1 import (
    _NO_MAP,
    JIT,
    GLayerParams,
    g_row,
    g_sum,
    sigmoid_potential,
    take_first_frames,
)
from lgmd_sim.params import finite, in_range, non_negative, param, positive, tuple_of

__all__ = ["LGMD2", "LGMD2Params", "low_pass_coefficient"]

_SRC = "fuqinbing/LGMD2-open-source lgmd2OpenSource.cs"
_SHARED = f"{_SRC}; the same in Ryannnice/Supplementary_Materials_FFI_ON_OFF optimized_LGMD.py"


@dataclass(frozen=True)
class LGMD2Params(GLayerParams):
    """Parameters of LGMD2; defaults from lgmd2OpenSource.cs (baselines.md)."""

    fps: float = param(30.0, "baselines.md: the published code assumes 30 fps; paper Sec. "
                       "4.1.2 (30 fps)", check=positive,
                       doc="frame rate that turns the time constants into per-frame "
                           "coefficients")
    carry: float = param(0.1, _SHARED, check=in_range(0.0, 1.0),
                         doc="part of the previous ON / OFF value carried over")
    tau_pm: float = param(90.0, _SRC, check=non_negative,
                          doc="time constant (ms) of the low-pass of mean |P| (PM)")
    t_pm: float = param(8.0, _SRC, check=positive,
                        doc="T_pm: W = max(w_min, PM / t_pm)")
    w_on_min: float = param(1.0, _SRC, check=non_negative,
                            doc="smallest inhibition weight of the ON channel")
    w_off_min: float = param(0.5, _SRC, check=non_negative,
                             doc="smallest inhibition weight of the OFF channel")
    on_weights: tuple[float, float, float] = param(
        (2.0, 0.5, 0.25), _SHARED, check=tuple_of(non_negative, 3),
        doc="ON inhibition kernel: (centre, each near, each diagonal) weight")
    on_delays: tuple[float, float, float] = param(
        (15.0, 30.0, 45.0), _SHARED, check=tuple_of(non_negative, 3),
        doc="ON inhibition delays (ms): (centre, near, diagonal) low-pass time constants")
    off_weights: tuple[float, float, float] = param(
        (1.0, 0.25, 0.125), _SHARED, check=tuple_of(non_negative, 3),
        doc="OFF inhibition kernel: (centre, each near, each diagonal) weight")
    off_delays: tuple[float, float, float] = param(
        (60.0, 120.0, 180.0), _SHARED, check=tuple_of(non_negative, 3),
        doc="OFF inhibition delays (ms): (centre, near, diagonal) low-pass time constants")
    t_sfa: float = param(0.003, _SRC, check=finite,
                         doc="SFA: a rise of K by at most t_sfa counts as no rise (adapt)")
    tau_sfa: float = param(800.0, _SHARED, check=non_negative,
                           doc="SFA time constant (ms) of the adapted potential's decay")


def low_pass_coefficient(tau_ms: float, fps: float) -> float:
    """First-order low-pass coefficient dt / (dt + tau) of a delay tau at a frame rate."""
    dt = 1000.0 / fps
    return dt / (dt + tau_ms)


class LGMD2(LGMDModel):
    """LGMD2: ON/OFF channels with adaptive delayed inhibition, G layer and SFA.

    The reported potential is the adapted one (after SFA). The published spike outputs
    (floor(exp(4 (K - 0.78)))) are not modelled: the project's metrics work on potentials.
    """

    name: ClassVar[str] = "lgmd2"
    Params: ClassVar[type[ModelParams]] = LGMD2Params
    layer_names: ClassVar[tuple[str, ...]] = ("P", "ON", "OFF", "S", "G")
    presets: ClassVar[dict[str, dict[str, Any]]] = {"published": {}}

    params: LGMD2Params

    def __init__(self, params: ModelParams | None = None, *, n_streams: int | None = None):
        super().__init__(params, n_streams=n_streams)
        p = self.params
        f32 = np.float32
        self._alphas = np.array(
            [low_pass_coefficient(t, p.fps) for t in (*p.on_delays, *p.off_delays)], f32)
        self._weights = np.array([*p.on_weights, *p.off_weights], f32)
        self._a_pm = low_pass_coefficient(p.tau_pm, p.fps)
        self._a_sfa = 1.0 - low_pass_coefficient(p.tau_sfa, p.fps)  # tau / (tau + dt)

    # -- state -------------------------------------------------------------------------

    def _allocate(self, n: int, height: int, width: int) -> None:
        self._prev = np.zeros((n, height, width), np.uint8)
        self._fresh = np.ones(n, bool)
        # ON, OFF, the low-passes (padded, replicated borders: ON centre, near, diagonal;
        # OFF the same) and the scratch lines, staggered (`staggered_arrays`): allocated
        # apart, they shared page offsets and ran 2x slower.
        self._on, self._off, self._lp, self._s_ring, self._vsum, self._q, self._ce_cols = (
            staggered_arrays([(n, height, width), (n, height, width),
                              (n, 6, height + 2, width + 2), (3, width + 2), (width + 2,),
                              (height, width), (width,)]))
        # Per stream: PM, PM_on, PM_off, mean ON, mean OFF; K and the adapted K (SFA).
        self._pm = np.zeros((n, 5))
        self._k = np.full(n, 0.5)
        self._adapted = np.full(n, 0.5)

    def _reset_streams(self, idx: np.ndarray) -> None:
        self._fresh[idx] = True
        for state in (self._on, self._off, self._lp, self._pm):
            state[idx] = 0.0
        self._k[idx] = 0.5
        self._adapted[idx] = 0.5

    # -- one frame ---------------------------------------------------------------------

    def _gates(self, pm_on: np.ndarray, pm_off: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per stream, 1 where the ON / OFF channel's S passes, 0 where it is gated off."""
        return np.ones_like(pm_on), np.ones_like(pm_off)

    def _step(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        self._prev = take_first_frames(grey, self._prev, self._fresh)
        p = self.params
        f32 = np.float32
        n, height, width = grey.shape
        n_cells = height * width
        sums = np.empty((n, 2))
        _rectified_sums(grey, self._prev, sums)
        # Means of ON(t) and OFF(t) follow from the sums, since ON(t) = [P]+ + carry ON(t-1).
        means = np.column_stack([(sums[:, 0] + sums[:, 1]), sums[:, 0], sums[:, 1]]) / n_cells
        means[:, 1:] += p.carry * self._pm[:, 3:5]
        self._pm[:, 3:5] = means[:, 1:]
        self._pm[:, :3] += self._a_pm * (means - self._pm[:, :3])  # PM, PM_on, PM_off
        pm = self._pm[:, 0]
        w_on = np.maximum(p.w_on_min, pm / p.t_pm).astype(f32)
        w_off = np.maximum(p.w_off_min, pm / p.t_pm).astype(f32)
        gate_on, gate_off = self._gates(self._pm[:, 1], self._pm[:, 2])
        maps = [layers[k] for k in self.layer_names] if layers else [_NO_MAP] * 5
        g_total = np.empty(n)
        _onoff_frames(
            grey, self._prev, self._on, self._off, self._lp, w_on, w_off,
            gate_on.astype(f32), gate_off.astype(f32), f32(p.carry), self._weights,
            self._alphas, p.delta_c, p.c_w, p.c_de, p.t_de, self._s_ring, self._vsum,
            self._q, self._ce_cols, layers is not None, *maps, g_total,
        )
        k = sigmoid_potential(g_total, n_cells, p.c_sig)
        self._adapted = spike_frequency_adaptation(
            k, self._k, self._adapted, p.t_sfa, self._a_sfa)
        self._k = k
        return self._adapted.copy()


def spike_frequency_adaptation(
    k: np.ndarray, k_prev: np.ndarray, adapted: np.ndarray, t_sfa: float, decay: float
) -> np.ndarray:
    """SFA: where K rose by more than t_sfa the adapted value follows K; elsewhere it takes
    the change of K and decays by ``decay`` = tau / (tau + dt) per frame; floor 0.5."""
    dk = k - k_prev
    return np.maximum(np.where(dk <= t_sfa, decay * (adapted + dk), k), 0.5)


# --- kernels ------------------------------------------------------------------------------


@njit(**JIT)
def _rectified_sums(frames, prev, out):
    """out[n] = (sum [P]+, sum [-P]+) of stream n's frame difference P."""
    n_streams, height, width = frames.shape
    zero = np.float32(0.0)
    for n in range(n_streams):
        pos = 0.0
        neg = 0.0
        for y in range(height):
            fr = frames[n, y]
            pr = prev[n, y]
            acc_pos = zero
            acc_neg = zero
            for x in range(width):
                p = np.float32(fr[x]) - np.float32(pr[x])
                acc_pos += max(p, zero)
                acc_neg += max(-p, zero)
            pos += acc_pos
            neg += acc_neg
        out[n, 0] = pos
        out[n, 1] = neg


@njit(**JIT)
def _inhibition(c1, n0, n1, n2, d0, d2, wc, wn, wd, x):
    """I at column x: the 3x3 kernel over the centre (c), near (n) and diagonal (d)
    low-passes, given as padded rows (index 0, 1, 2: rows y-1, y, y+1)."""
    return wc * c1[x + 1] + wn * (n0[x + 1] + n2[x + 1] + n1[x] + n1[x + 2]) + wd * (
        d0[x] + d0[x + 2] + d2[x] + d2[x + 2])


#: Decaying state (ON, OFF, the low-passes) below this many grey levels is set to 0: left
#: alone it would sink into subnormal floats, which x86 processes about 100 times slower,
#: and a first-order decay sticks at the smallest subnormal for good. Far below the input's
#: resolution of one grey level; the float64 reference does not need it.
_FLUSH = np.float32(1e-6)


@njit(**JIT)
def _low_pass_row(lp_row, source, alpha):
    """One padded row of a first-order low-pass: lp += alpha (source - lp); borders filled."""
    width = source.shape[0]
    zero = np.float32(0.0)
    for x in range(width):
        v = lp_row[x + 1] + alpha * (source[x] - lp_row[x + 1])
        lp_row[x + 1] = v if v >= _FLUSH else zero
    fill_borders(lp_row, 1, width)


@njit(**JIT)
def _onoff_frames(frames, prev, on, off, lp, w_on, w_off, gate_on, gate_off, carry,
                  weights, alphas, delta_c, c_w, c_de, t_de, s_ring, vsum, q, ce_cols,
                  want, l_p, l_on, l_off, l_s, l_g, g_total):
    """One frame per stream of the ON/OFF models, up to sum G.

    The low-passes hold the previous frames' ON / OFF (delay of at least one frame): S of
    row y reads rows y-1..y+1 of them, so row y-1 is advanced to ON(t) / OFF(t) one row
    late. G of row y-1 follows once S of row y is in the ring.
    """
    n_streams, height, width = frames.shape
    zero = np.float32(0.0)
    wc_on, wn_on, wd_on = weights[0], weights[1], weights[2]
    wc_off, wn_off, wd_off = weights[3], weights[4], weights[5]
    for n in range(n_streams):
        won = w_on[n]
        woff = w_off[n]
        g_on = gate_on[n]
        g_off = gate_off[n]
        ce_cols[:] = zero
        for y in range(height + 1):
            if y < height:
                fr = frames[n, y]
                pr = prev[n, y]
                onr = on[n, y]
                offr = off[n, y]
                if want:
                    for x in range(width):
                        l_p[n, y, x] = np.float32(fr[x]) - np.float32(pr[x])
                ln = lp[n]
                c_on, n0_on, n1_on, n2_on = ln[0, y + 1], ln[1, y], ln[1, y + 1], ln[1, y + 2]
                d0_on, d2_on = ln[2, y], ln[2, y + 2]
                c_of, n0_of, n1_of, n2_of = ln[3, y + 1], ln[4, y], ln[4, y + 1], ln[4, y + 2]
                d0_of, d2_of = ln[5, y], ln[5, y + 2]
                sr = s_ring[y % 3]
                for x in range(width):
                    p = np.float32(fr[x]) - np.float32(pr[x])
                    pr[x] = fr[x]
                    vo = max(p, zero) + carry * onr[x]  # ON
                    vo = vo if vo >= _FLUSH else zero
                    onr[x] = vo
                    vf = max(-p, zero) + carry * offr[x]  # OFF
                    vf = vf if vf >= _FLUSH else zero
                    offr[x] = vf
                    i_on = _inhibition(c_on, n0_on, n1_on, n2_on, d0_on, d2_on, wc_on, wn_on,
                                       wd_on, x)
                    i_off = _inhibition(c_of, n0_of, n1_of, n2_of, d0_of, d2_of, wc_off, wn_off,
                                        wd_off, x)
                    s_on = max(vo - won * i_on, zero) * g_on  # S_on = [ON - W_on I_on]+
                    s_off = max(vf - woff * i_off, zero) * g_off  # S_off = [OFF - W_off I_off]+
                    sr[x + 1] = s_on + s_off + s_on * s_off
                fill_borders(sr, 1, width)
                if want:
                    l_on[n, y] = onr
                    l_off[n, y] = offr
                    l_s[n, y] = sr[1:width + 1]
            if y >= 1:
                for k in range(3):
                    _low_pass_row(lp[n, k, y], on[n, y - 1], alphas[k])
                    _low_pass_row(lp[n, k + 3, y], off[n, y - 1], alphas[k + 3])
                g_row(s_ring[ring_slot(y - 2, height, 3)], s_ring[(y - 1) % 3],
                      s_ring[ring_slot(y, height, 3)], vsum, q[y - 1], ce_cols)
        for k in range(6):  # replicated top and bottom borders
            lp[n, k, 0] = lp[n, k, 1]
            lp[n, k, height + 1] = lp[n, k, height]
        g_total[n] = g_sum(q, ce_cols, delta_c, c_w, c_de, t_de, want,
                           l_g[n] if want else q)
