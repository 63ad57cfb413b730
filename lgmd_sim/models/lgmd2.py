"""LGMD2 (Fu et al., IEEE TCYB 2020): ON/OFF channels, adaptive delayed inhibition, SFA.

Layers, per frame t (grey levels 0..255), with the switches that tell the published
implementations apart (docs/reference/models.md, "Baselines"):

- P = L(t) - L(t-1), 0 on the first frame of a stream (plus ``persistence``).
- ON = [P]+ + carry ON(t-1), OFF = [-P]+ + carry OFF(t-1).
- PM: the mean activity, from the whole field (mean |P|) and per channel (mean ON, mean
  OFF), each filtered with ``tau_pm`` (``pm_filter``: a recursive low-pass, or a two-tap
  filter of this frame's and the last frame's mean). W_on = max(w_on_min, PM / t_pm),
  W_off = max(w_off_min, PM / t_pm), from the whole-field or each channel's PM
  (``pm_weights``).
- Delayed inhibition: for each channel and each of the centre, near and diagonal cells a
  delayed copy with coefficient a = dt / (dt + tau): ``inhibition_filter`` "two-frame"
  mixes the current and the previous frame, a X(t) + (1 - a) X(t-1) (the published
  code); "low-pass" low-passes the previous frames only. I = the 3x3 sum of the delayed
  copies weighted by the centre / near / diagonal weights.
- S_on = [ON - W_on I_on]+, S_off = [OFF - W_off I_off]+, S = S_on + S_off +
  onoff_product S_on S_off; a channel's S is gated off (``ffi_channels``) while its PM is
  below ``ffi_gate``.
- G layer and sigmoid as in LGMD1 (`lgmd_sim.models.baseline`), over sum G: K. A global FFI
  (``global_ffi_base``) sets K to 0.5 when PM_on + PM_off jumps.
- Spike-frequency adaptation (SFA) of K: the reported potential.

The F(ON)/F(OFF) LGMDs (`lgmd_sim.models.ffi`) are this model with the oLGMD's values.
The kernels that run a frame are in `lgmd_sim.models.onoff_kernels`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from lgmd_sim.core.params import (
    because,
    finite,
    in_range,
    non_negative,
    one_of,
    optional,
    param,
    positive,
    tuple_of,
)
from lgmd_sim.models.base import LGMDModel, ModelParams, StateMap
from lgmd_sim.models.baseline import (
    NO_MAP,
    SIGMOID_SEARCH,
    BaselineParams,
    boolean,
    border_code,
    persistence_weights,
    sigmoid_potential,
    take_first_frames,
)
from lgmd_sim.models.kernels import staggered_arrays
from lgmd_sim.models.onoff_kernels import onoff_frames, rectified_sums
from lgmd_sim.models.search import SearchRange
from lgmd_sim.models.sources import SOURCES

__all__ = ["LGMD2", "LGMD2Params", "frame_interval", "low_pass_coefficient",
           "spike_frequency_adaptation"]

_SRC = SOURCES["lgmd2"]
_OL = SOURCES["olgmd"]
_SHARED = f"{_SRC}; the same in {_OL}"


@dataclass(frozen=True)
class LGMD2Params(BaselineParams):
    """Parameters of LGMD2; defaults: lgmd2OpenSource.cs (preset ``published``)."""

    fps: float = param(30.0, "paper Sec. 4.1.2 (30 fps); lgmd2OpenSource.cs takes fps as a "
                       "constructor argument", check=positive,
                       doc="frame rate that turns the time constants into per-frame "
                           "coefficients (see dt)")
    dt: float | None = param(None, f"{_SRC}: time_interval from fps (53 ms fixed in {_OL})",
                             check=optional(positive),
                             doc="frame interval (ms) the time constants are applied with; "
                                 "None: from fps (see dt_integer)")
    dt_integer: bool = param(True, f"{_SRC}: time_interval = 1000 / fps in C# integer "
                             "arithmetic (33 ms at 30 fps)", check=boolean,
                             doc="with dt None: dt = 1000 // fps whole milliseconds (True) "
                                 "or 1000 / fps (False)")
    carry: float = param(0.1, f"{_SHARED} (dc; a1)", check=in_range(0.0, 1.0),
                         doc="part of the previous ON / OFF value carried over")
    tau_pm: float = param(90.0, f"{_SRC} (tau_PM; 10 in {_OL})", check=non_negative,
                          doc="time constant (ms) of the PM filter")
    pm_filter: str = param("low-pass", f"{_SRC}: pm = LowpassFilter(mean, pm(t-1))",
                           check=one_of("low-pass", "two-tap"),
                           doc="'low-pass': PM(t) = PM(t-1) + a (m(t) - PM(t-1)); "
                               "'two-tap': PM(t) = a m(t) + (1 - a) m(t-1) (the oLGMD); "
                               "a = dt / (dt + tau_pm), m the frame's mean")
    pm_weights: str = param("whole-field", f"{_SRC}: W_i_on and W_i_off from mean |P|",
                            check=one_of("whole-field", "per-channel"),
                            doc="W_on and W_off from the PM of mean |P| ('whole-field') or "
                                "W_on from PM_on (mean ON), W_off from PM_off (mean OFF)")
    pm_off_uses_on_mean: bool = param(
        False, f"ours: off; True is {_OL} as written (PM_ff = a4 * pmon + ...), a bug",
        check=boolean,
        doc="the current term of PM_off takes the mean of ON instead of OFF")
    t_pm: float = param(8.0, f"{_SRC} (Tpm; 6 in {_OL})", check=positive,
                        doc="T_pm: W = max(w_min, PM / t_pm)")
    w_on_min: float = param(1.0, f"{_SHARED} (W_i_on_base; w3)", check=non_negative,
                            doc="smallest inhibition weight of the ON channel")
    w_off_min: float = param(0.5, f"{_SRC} (W_i_off_base; 0.3 in {_OL})", check=non_negative,
                             doc="smallest inhibition weight of the OFF channel")
    on_weights: tuple[float, float, float] = param(
        (2.0, 0.5, 0.25), f"{_SHARED} (Conv_ON; W1_kernel)", check=tuple_of(non_negative, 3),
        doc="ON inhibition kernel: (centre, each near, each diagonal) weight")
    on_delays: tuple[float, float, float] = param(
        (15.0, 30.0, 45.0), f"{_SHARED} (tau_ON; t3, t2, t1)", check=tuple_of(non_negative, 3),
        doc="ON inhibition delays (ms): (centre, near, diagonal) time constants")
    off_weights: tuple[float, float, float] = param(
        (1.0, 0.25, 0.125), f"{_SHARED} (Conv_OFF; W2_kernel)", check=tuple_of(non_negative, 3),
        doc="OFF inhibition kernel: (centre, each near, each diagonal) weight")
    off_delays: tuple[float, float, float] = param(
        (60.0, 120.0, 180.0), f"{_SHARED} (tau_OFF; t6, t5, t4)",
        check=tuple_of(non_negative, 3),
        doc="OFF inhibition delays (ms): (centre, near, diagonal) time constants")
    inhibition_filter: str = param(
        "two-frame", f"{_SHARED}: LowpassFilter(X(t), X(t-1)) inside the convolution",
        check=one_of("two-frame", "low-pass"),
        doc="'two-frame': each delayed copy is a X(t) + (1 - a) X(t-1) of the current and "
            "previous frame; 'low-pass': X(t-1), X(t-2)... low-passed (ours, v0.1)")
    onoff_product: float = param(1.0, f"{_SRC} (W_onoff; o3 = 0 in {_OL})", check=finite,
                                 doc="coefficient of S_on * S_off in S")
    ffi_channels: str = param(
        "none", f"{_SRC}: no FFI (both channels in {_OL})",
        check=one_of("none", "on", "off", "both"),
        doc="channels whose S is gated off while their PM (PM_on, PM_off) is below ffi_gate")
    ffi_gate: float = param(1.15, f"{_OL} (oon, ooff)", check=non_negative,
                            doc="a gated channel's S passes only while its PM >= ffi_gate")
    ffi_gates_history: bool = param(
        True, f"{_OL}: E = P_on / P_off is only set while the gate is open",
        check=boolean,
        doc="a gated-off channel also feeds nothing (E = 0) to the next frame's inhibition "
            "(False: the gate zeroes S only; v0.1)")
    global_ffi_base: float | None = param(
        None, f"{_SRC}: none (10 in {_OL}: AIM(t) >= 10 + 0.02 AIM(t-1))",
        check=optional(because(positive, "at 0 the global FFI holds K at 0.5 on every "
                                         "frame; None turns it off")),
        doc="global FFI: K is set to 0.5 (before SFA) while PM_on + PM_off >= "
            "global_ffi_base + global_ffi_gain * (its previous value); None: off")
    global_ffi_gain: float = param(0.02, _OL, check=non_negative,
                                   doc="see global_ffi_base")
    t_sfa: float = param(0.003, f"{_SRC} (Tsfa; 0.002 in {_OL})", check=finite,
                         doc="SFA: a rise of K by at most t_sfa counts as no rise (adapt)")
    tau_sfa: float = param(800.0, f"{_SHARED} (tau_sfa; a6 = 800 / (800 + t))",
                           check=because(positive, "at 0 the SFA decay is 0 and the "
                                         "potential a constant 0.5"),
                           doc="SFA time constant (ms): decay = tau / (tau + dt) per frame")
    sfa_rise: str = param("decay", f"{_SHARED}: SFA_HPF returns hp_sfa * K on a rise",
                          check=one_of("decay", "follow"),
                          doc="where K rose by more than t_sfa the adapted potential is "
                              "decay * K ('decay') or K ('follow', ours, v0.1)")


def frame_interval(p: LGMD2Params) -> float:
    """The frame interval dt (ms) the time constants are applied with."""
    if p.dt is not None:
        return float(p.dt)
    return float(1000.0 // p.fps) if p.dt_integer else 1000.0 / p.fps


def low_pass_coefficient(tau_ms: float, dt_ms: float) -> float:
    """First-order coefficient dt / (dt + tau) of a delay tau at a frame interval dt."""
    return dt_ms / (dt_ms + tau_ms)


def spike_frequency_adaptation(
    k: np.ndarray, k_prev: np.ndarray, adapted: np.ndarray, t_sfa: float, decay: float,
    follow: bool,
) -> np.ndarray:
    """SFA: where K rose by more than t_sfa the adapted value is K (``follow``) or decay K;
    elsewhere it takes the change of K and decays by ``decay`` = tau / (tau + dt) per
    frame; floor 0.5."""
    dk = k - k_prev
    rise = k if follow else decay * k
    return np.maximum(np.where(dk <= t_sfa, decay * (adapted + dk), rise), 0.5)


class LGMD2(LGMDModel):
    """LGMD2: ON/OFF channels with adaptive delayed inhibition, G layer and SFA.

    The reported potential is the adapted one (after SFA). The published spike outputs
    (floor(exp(4 (K - 0.78)))) are not modelled: the project's metrics work on potentials.
    """

    name: ClassVar[str] = "lgmd2"
    Params: ClassVar[type[ModelParams]] = LGMD2Params
    layer_names: ClassVar[tuple[str, ...]] = ("P", "ON", "OFF", "S", "G")
    presets: ClassVar[dict[str, dict[str, Any]]] = {
        "published": {},  # lgmd2OpenSource.cs
        # this project's first reading: low-passed previous frames, SFA following K
        "v0.1": {"dt_integer": False, "inhibition_filter": "low-pass", "sfa_rise": "follow"},
    }
    search_space: ClassVar[dict[str, SearchRange]] = SIGMOID_SEARCH  # the oLGMDs' too

    params: LGMD2Params

    def __init__(self, params: ModelParams | None = None, *, n_streams: int | None = None):
        super().__init__(params, n_streams=n_streams)
        p = self.params
        dt = frame_interval(p)
        self._alphas = np.array(
            [low_pass_coefficient(t, dt) for t in (*p.on_delays, *p.off_delays)], np.float32)
        self._weights = np.array([*p.on_weights, *p.off_weights], np.float32)
        self._a_pm = low_pass_coefficient(p.tau_pm, dt)
        self._decay_sfa = 1.0 - low_pass_coefficient(p.tau_sfa, dt)  # tau / (tau + dt)
        self._border, self._interior = border_code(p.border)
        self._gated = np.array([p.ffi_channels in ("on", "both"),
                                p.ffi_channels in ("off", "both")])

    # -- state -------------------------------------------------------------------------

    def allocate(self, n: int, height: int, width: int) -> None:
        p = self.params
        self._prev = np.zeros((n, height, width), np.uint8)
        self._fresh = np.ones(n, bool)
        # State: ON, OFF; the low-passes (ON centre, near, diagonal; OFF the same) where
        # inhibition_filter is "low-pass" (else a 3-row ring of the current mix, scratch);
        # P(t-1), P(t-2) where persistence runs. Rows of the low-passes, the ring and the S
        # ring are padded by a column each side and followed by a row of zeros (a border
        # row under border "zero"). Staggered (`staggered_arrays`): allocated apart, they
        # shared page offsets and ran 2x slower.
        low_pass = p.inhibition_filter == "low-pass"
        hist = (n, 2, height, width) if p.persistence != "none" else (1, 2, 1, 1)
        (self._on, self._off, self._lp, self._mix, self._p_hist, self._s_ring, self._lines,
         self._vsum, self._q, self._ce_cols) = staggered_arrays([
            (n, height, width), (n, height, width),
            (n, 6, height + 1, width + 2) if low_pass else (1, 6, 1, width + 2),
            (6, 4, width + 2), hist, (4, width + 2), (3, width), (width + 2,),
            (height, width), (width,)])
        # Per stream: the last frame's means (|P|, ON, OFF), the PM filters' outputs
        # (PM, PM_on, PM_off), PM_on + PM_off, the gates' history factors (ON, OFF);
        # K and the adapted K (SFA).
        self._m_prev = np.zeros((n, 3))
        self._pm = np.zeros((n, 3))
        self._aim = np.zeros(n)
        self._hist = np.ones((n, 2), np.float32)
        self._frame_index = np.zeros(n, np.int64)
        self._k = np.full(n, 0.5)
        self._adapted = np.full(n, 0.5)

    def reset_streams(self, idx: np.ndarray) -> None:
        self._fresh[idx] = True
        for state in (self._on, self._off, self._m_prev, self._pm, self._aim):
            state[idx] = 0.0
        if self._lp.shape[0] == self._n:
            self._lp[idx] = 0.0
        if self._p_hist.shape[0] == self._n:
            self._p_hist[idx] = 0.0
        self._hist[idx] = 1.0
        self._frame_index[idx] = 0
        self._k[idx] = 0.5
        self._adapted[idx] = 0.5

    def state_maps(self) -> list[StateMap]:
        maps = [StateMap("_prev", "frame"), StateMap("_on"), StateMap("_off")]
        if self.params.inhibition_filter == "low-pass":
            maps.append(StateMap("_lp", padded=self._border))
        return maps + ([StateMap("_p_hist")] if self.params.persistence != "none" else [])

    def maps_moved(self) -> None:
        # ON(t) = [P]+ + carry ON(t-1) takes its mean from ON(t-1)'s: now the warped one's
        n_cells = self._on[0].size
        for i in range(self._n):
            self._m_prev[i, 1] = self._on[i].sum(dtype=np.float64) / n_cells
            self._m_prev[i, 2] = self._off[i].sum(dtype=np.float64) / n_cells

    # -- one frame ---------------------------------------------------------------------

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        self._prev = take_first_frames(grey, self._prev, self._fresh)
        p = self.params
        f32 = np.float32
        n, height, width = grey.shape
        n_cells = height * width
        weights, persist = persistence_weights(p.persistence, p.persistence_weights,
                                               self._frame_index)
        sums = np.empty((n, 2))
        rectified_sums(grey, self._prev, self._p_hist, weights, persist, self._lines[0], sums)
        # Means of |P|, ON(t), OFF(t); those of ON and OFF follow from the sums, since
        # ON(t) = [P]+ + carry ON(t-1).
        m = np.column_stack([sums[:, 0] + sums[:, 1], sums[:, 0], sums[:, 1]]) / n_cells
        m[:, 1:] += p.carry * self._m_prev[:, 1:]
        current = m.copy()
        if p.pm_off_uses_on_mean:
            current[:, 2] = m[:, 1]
        a = self._a_pm
        if p.pm_filter == "two-tap":
            self._pm = a * current + (1.0 - a) * self._m_prev
        else:
            self._pm = self._pm + a * (current - self._pm)
        self._m_prev = m
        pm = self._pm
        per_channel = p.pm_weights == "per-channel"
        w_on = np.maximum(p.w_on_min, pm[:, 1 if per_channel else 0] / p.t_pm).astype(f32)
        w_off = np.maximum(p.w_off_min, pm[:, 2 if per_channel else 0] / p.t_pm).astype(f32)
        gates = np.where(self._gated, pm[:, 1:] >= p.ffi_gate, True).astype(f32)
        hist = gates if p.ffi_gates_history else np.ones_like(gates)
        maps = [layers[k] for k in self.layer_names] if layers else [NO_MAP] * 5
        g_total = np.empty(n)
        onoff_frames(
            grey, self._prev, self._on, self._off, self._lp, self._mix, self._p_hist,
            weights, persist, w_on, w_off, gates, hist, self._hist, f32(p.carry),
            self._weights, self._alphas, p.inhibition_filter == "two-frame",
            f32(p.onoff_product), self._border, self._interior, p.delta_c, p.c_w, p.c_de,
            p.t_de, self._s_ring, self._lines, self._vsum, self._q, self._ce_cols,
            layers is not None, *maps, g_total,
        )
        self._hist = hist
        self._frame_index += 1
        k = sigmoid_potential(g_total, n_cells, p.c_sig)
        if p.global_ffi_base is not None:
            aim = pm[:, 1] + pm[:, 2]
            k[aim >= p.global_ffi_base + p.global_ffi_gain * self._aim] = 0.5
            self._aim = aim
        self._adapted = spike_frequency_adaptation(
            k, self._k, self._adapted, p.t_sfa, self._decay_sfa, p.sfa_rise == "follow")
        self._k = k
        return self._adapted.copy()
