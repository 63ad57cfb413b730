"""The feedback LGMD of the paper (Sec. 3, Eq. 5-20), as one fused numba kernel per frame.

Layers, per frame t (grey levels 0..255):

- P (Eq. 5): the frame difference; 0 on the first frame of a stream.
- P_on, P_off (Eq. 6, 7): half-wave rectified P plus the feedback ``beta * Phi``.
- E (Eq. 8, 14): P_on / P_off blurred by the Gaussian of sigma1.
- I (Eq. 10-12, 15): P_on / P_off of the previous frames, weighted by the sampled delay
  filter phi(j) = 2 exp(-pi j^2), j = 1..delay_taps frames, blurred by sigma2.
- S (Eq. 13, 16, 17): eps1 [E_on - alpha I_on]^+ + eps2 [E_off - alpha I_off]^+.
- D (Eq. 18): sum of |S(t-s) - S(t-s-1)| over the last tv_window frames before t.
- Phi (Eq. 19): sum_i zeta_i N_m(|rho D - eta_i K| + m/2), the radial cardinal B-spline.
- The membrane potential (Eq. 20): 1 / (1 + exp(-sum S / (R C mu))), in [0.5, 1).

Phi(t) uses D from frames before t only, so the loop is causal: Phi(t) feeds P_on(t),
which makes S(t). Every reading of an ambiguity of the paper is a named parameter; see
docs/reference/models.md. `lgmd_sim.models.reference.feedback` is the per-equation float64
version this one is tested against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit

from lgmd_sim.core.params import (
    finite,
    in_range,
    int_at_least,
    int_in_range,
    non_negative,
    one_of,
    param,
    positive,
    tuple_of,
)
from lgmd_sim.models.base import LGMDModel, ModelParams, StateMap
from lgmd_sim.models.kernels import (
    JIT,
    fill_borders,
    gaussian_taps,
    hconv,
    ordered_sum,
    staggered_arrays,
    vconv,
)
from lgmd_sim.models.search import SearchRange

__all__ = [
    "TABLE_1",
    "FeedbackLGMD",
    "FeedbackParams",
    "delay_weights",
    "membrane_potential",
    "spline_coefficients",
]

#: Highest B-spline order accepted; beyond it the spline is a near-Gaussian bump anyway.
MAX_SPLINE_ORDER = 8
#: Bounds that keep memory and time sane: Gaussians of sigma 20 px already span 121 px;
#: phi(j) of Eq. 12 is below float32 resolution from j = 3 on; T = 120 frames is 4 s at
#: 30 fps (D keeps T maps); more than 8 spline terms were never asked for.
MAX_SIGMA, MAX_DELAY_TAPS, MAX_TV_WINDOW, MAX_TERMS = 20.0, 8, 120, 8


def _spline_order(v: Any) -> str | None:
    ok = isinstance(v, int | np.integer) and not isinstance(v, bool)
    return None if ok and 2 <= v <= MAX_SPLINE_ORDER else (
        f"must be an integer in [2, {MAX_SPLINE_ORDER}]"
    )


@dataclass(frozen=True)
class FeedbackParams(ModelParams):
    """Parameters of the feedback LGMD; defaults are the literal values of the paper's Table 1."""

    beta1: float = param(-0.01, "paper Table 1 (Eq. 6); Sec. 4.1.1 says 0.001", check=finite,
                         doc="feedback coefficient of the ON channel")
    beta2: float = param(0.003, "paper Table 1 (Eq. 7); Sec. 4.1.1 says -0.01", check=finite,
                         doc="feedback coefficient of the OFF channel")
    feedback_gain: float = param(
        1.0, "ours: 1 is the paper's literal loop (docs/reference/models.md, choice 2)",
        check=non_negative,
        doc="multiplies beta1 and beta2: the loop's gain (0 opens the loop)")
    sigma1: float = param(0.1, "paper Table 1 (Eq. 8, 14)", check=in_range(1e-6, MAX_SIGMA),
                          doc="s.d. of the excitation Gaussian, pixels")
    sigma2: float = param(0.3, "paper Table 1 (Eq. 10, 15)", check=in_range(1e-6, MAX_SIGMA),
                          doc="s.d. of the inhibition Gaussian, pixels")
    alpha: float = param(0.1, "paper Table 1 (Eq. 13, 16)", check=non_negative,
                         doc="inhibition coefficient")
    eps1: float = param(0.2, "paper Table 1 (Eq. 17)", check=non_negative,
                        doc="weight of the ON channel in S")
    eps2: float = param(0.2, "paper Table 1 (Eq. 17)", check=non_negative,
                        doc="weight of the OFF channel in S")
    rho: float = param(1.0, "paper Table 1 (Eq. 19)", check=positive,
                       doc="scale of D in the spline's argument")
    eta: tuple[float, ...] = param(
        (100.0, 300.0),
        "paper Table 1 (Eq. 19); one spline term per value (docs/reference/models.md, choice 3)",
        check=tuple_of(finite, max_length=MAX_TERMS),
        doc="translation of each spline term (centre eta_i K)")
    zeta: tuple[float, ...] = param(
        (0.5, 1.0), "paper Table 1 (Eq. 19); pairs with eta (docs/reference/models.md, choice 3)",
        check=tuple_of(finite, max_length=MAX_TERMS), doc="weight of each spline term")
    spline_order: int = param(
        4, "ours: cubic, the usual choice; the paper leaves m open (docs/reference/models.md, "
        "choice 4)",
        check=_spline_order, doc="order m of the cardinal B-spline N_m (4: cubic)")
    k_mode: str = param(
        "constant", "ours (docs/reference/models.md, choice 5): Eq. 19 calls K an integer",
        check=one_of("constant", "potential"),
        doc="K of Eq. 19: the integer k, or the previous frame's membrane potential")
    k: int = param(1, "ours (docs/reference/models.md, choice 5): K = 1 centres the terms at eta",
                   check=int_at_least(0), doc="K when k_mode is 'constant'")
    delay_taps: int = param(
        2, "ours (docs/reference/models.md, choice 6): phi(3)/phi(1) = 1.2e-11, below float32 "
        "resolution",
        check=int_in_range(1, MAX_DELAY_TAPS),
        doc="frames of delayed inhibition (delays 1..delay_taps)")
    tv_window: int = param(
        5, "ours (docs/reference/models.md, choice 8): 1/6 s at 30 fps",
        check=int_in_range(1, MAX_TV_WINDOW), doc="T of Eq. 18: frames of |dS/dt| summed into D")
    mu: float = param(
        3.0, "ours (docs/reference/models.md, choice 9): the synthetic approaches cross 0.8 in "
        "their last 10%, receding and translating objects stay below 0.68",
        check=positive,
        doc="scale of the sigmoid of Eq. 20: potential 0.8 at a mean S per pixel of 1.39 mu")

    def __post_init__(self) -> None:
        super().__post_init__()
        # Hashable, float-typed pairs whatever sequence the caller passed.
        object.__setattr__(self, "eta", tuple(float(v) for v in self.eta))
        object.__setattr__(self, "zeta", tuple(float(v) for v in self.zeta))
        if not self.eta or len(self.eta) != len(self.zeta):
            raise ValueError(f"{type(self).__name__}.eta and .zeta must have the same length "
                             f">= 1 (one spline term each), got {len(self.eta)} and "
                             f"{len(self.zeta)}")
        if self.eps1 == 0 and self.eps2 == 0:
            raise ValueError(f"{type(self).__name__}: parameters eps1=0 and eps2=0: at least "
                             "one must be > 0 (with both 0, S is 0 and the potential a "
                             "constant 0.5)")


def delay_weights(n_taps: int) -> np.ndarray:
    """Eq. 11-12 on frames: phi(j) = 2 exp(-pi j^2) at delays j = 1..n_taps, summing to 1."""
    j = np.arange(1, n_taps + 1, dtype=np.float64)
    w = 2.0 * np.exp(-math.pi * j * j)
    return w / w.sum()


def spline_coefficients(order: int) -> np.ndarray:
    """c_k with N_m(|u| + m/2) = sum_k c_k (m/2 - k - |u|)_+^(m-1), k < m/2.

    The truncated-power form of the cardinal B-spline, mirrored onto its rising half:
    only terms with k < m/2 survive, so it is exactly 0 for |u| >= m/2 and never
    cancels large numbers.
    """
    ks = range(math.ceil(order / 2))
    return np.array([(-1) ** k * math.comb(order, k) / math.factorial(order - 1) for k in ks])


#: The paper's Table 1, literally.
TABLE_1: dict[str, Any] = {
    "beta1": -0.01, "beta2": 0.003, "sigma1": 0.1, "sigma2": 0.3, "alpha": 0.1, "eps1": 0.2,
    "eps2": 0.2, "rho": 1.0, "eta": (100.0, 300.0), "zeta": (0.5, 1.0),
}


class FeedbackLGMD(LGMDModel):
    """Feedback LGMD (the paper's Eq. 5-20): a looming detector with a B-spline feedback loop."""

    name: ClassVar[str] = "feedback"
    Params: ClassVar[type[ModelParams]] = FeedbackParams
    layer_names: ClassVar[tuple[str, ...]] = ("P", "S", "D", "Phi")
    presets: ClassVar[dict[str, dict[str, Any]]] = {
        "paper": TABLE_1,
        # Table 1 with the feedback coefficients of Sec. 4.1.1
        "paper-text": {**TABLE_1, "beta1": 0.001, "beta2": -0.01},
    }
    # The free parameters of docs/reference/models.md, choices 2-9, loop closed. Drawn in this
    # order, that of the first calibration's sampler, so that its seeds give the same
    # candidates.
    search_space: ClassVar[dict[str, SearchRange]] = {
        "eta[0]": SearchRange(0.5, 200.0),
        "feedback_gain": SearchRange(1.0, 1e6),
        "rho": SearchRange(0.01, 10.0),
        "eta[1]": SearchRange(1.5, 4.0, log=False, times="eta[0]"),  # the slower one
        "zeta[0]": SearchRange(0.2, 1.0, log=False),
        "zeta[1]": SearchRange(0.2, 1.0, log=False),
        "tv_window": SearchRange(choices=(3, 5, 8, 12)),
        "k_mode": SearchRange(choices=("constant", "potential")),
        "mu": SearchRange(0.3, 10.0),
    }

    params: FeedbackParams

    def __init__(self, params: ModelParams | None = None, *, n_streams: int | None = None):
        super().__init__(params, n_streams=n_streams)
        p = self.params
        f32 = np.float32
        # Tuples: the kernel is compiled for their lengths, so its loops over them unroll.
        self._g1 = gaussian_taps(p.sigma1)
        self._g2 = gaussian_taps(p.sigma2)
        self._delay = tuple(f32(v) for v in delay_weights(p.delay_taps))
        self._spline = tuple(f32(v) for v in spline_coefficients(p.spline_order))
        self._eta = tuple(f32(v) for v in p.eta)
        self._zeta = tuple(f32(v) for v in p.zeta)
        self._scalars = tuple(f32(v) for v in (
            p.rho, p.feedback_gain * p.beta1, p.feedback_gain * p.beta2, p.alpha, p.eps1,
            p.eps2))

    # -- state -------------------------------------------------------------------------

    def allocate(self, n: int, height: int, width: int) -> None:
        p = self.params
        # The previous frame stays uint8 (4x less memory traffic) until a float frame comes.
        self._prev = np.zeros((n, height, width), np.uint8)
        self._has_prev = np.zeros(n, bool)
        self._potential_prev = np.full(n, 0.5)
        frame = (height, width)
        (self._pon_hist, self._poff_hist, self._s_prev, self._ds_hist, self._d) = (
            staggered_arrays([(n, p.delay_taps, *frame), (n, p.delay_taps, *frame), (n, *frame),
                              (n, p.tv_window, *frame), (n, *frame)]))
        self._t = 0  # frame counter shared by all streams: it picks the ring slots

    def reset_streams(self, idx: np.ndarray) -> None:
        for state in (self._pon_hist, self._poff_hist, self._s_prev, self._ds_hist, self._d):
            state[idx] = 0.0
        self._has_prev[idx] = False
        self._potential_prev[idx] = 0.5

    def state_maps(self) -> list[StateMap]:
        return [StateMap("_prev", "frame"), *(StateMap(a) for a in (
            "_pon_hist", "_poff_hist", "_s_prev", "_ds_hist"))]

    def maps_moved(self) -> None:
        # D, the running sum of the |dS| history, summed afresh from the warped history
        self._d[:] = self._ds_hist[:, 0]
        for t in range(1, self._ds_hist.shape[1]):
            self._d += self._ds_hist[:, t]

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        if grey.dtype != np.uint8 and self._prev.dtype == np.uint8:
            self._prev = self._prev.astype(np.float32)
        if not self._has_prev.all():  # Eq. 5 on a stream's first frame: P = 0
            first = ~self._has_prev
            self._prev[first] = grey[first]
            self._has_prev[:] = True
        n, height, width = grey.shape
        if self.params.k_mode == "potential":  # K of Eq. 19: the last membrane potential
            k = self._potential_prev.astype(np.float32)
        else:
            k = np.full(n, self.params.k, np.float32)
        if layers is None:
            maps = (np.empty((0, 0, 0), np.float32),) * 4
        else:
            maps = tuple(layers[name] for name in self.layer_names)
        s_sum = np.empty(n)
        _feedback_frames(
            grey, self._prev, self._pon_hist, self._poff_hist, self._s_prev, self._ds_hist,
            self._d, self._t, k, self._g1, self._g2, self._delay, self._eta, self._zeta,
            self._spline, self.params.spline_order, self._scalars, layers is not None,
            *maps, s_sum,
        )
        potential = membrane_potential(s_sum, height * width, self.params.mu)
        self._potential_prev = potential.copy()  # the caller gets potential itself
        self._t += 1
        return potential


def membrane_potential(s_sum: np.ndarray, n_cells: int, mu: float) -> np.ndarray:
    """Eq. 20: 1 / (1 + exp(-sum S / (R C mu))), in [0.5, 1) for sum S >= 0."""
    return 1.0 / (1.0 + np.exp(-np.asarray(s_sum, np.float64) / (n_cells * mu)))


# --- the kernel ---------------------------------------------------------------------------


@njit(**JIT)
def _phi_row(d_row, rho, k, eta, zeta, spline, order, out):
    """Eq. 19 for one row: out = sum_i zeta_i N_m(|rho D - eta_i K| + m/2).

    N_m(|u| + m/2) is exactly 0 for |u| >= m/2, so a row whose D keeps that far from
    every centre eta_i K is 0 without the per-pixel work: the usual case.
    """
    zero = np.float32(0.0)
    if not _spline_reaches(d_row, rho, k, eta, order):
        out[:] = zero
        return
    if order == 4:  # the default: every term, both cubic pieces, one branch-free loop
        two = np.float32(2.0)
        one = np.float32(1.0)
        for x in range(out.shape[0]):
            rd = rho * d_row[x]
            acc = zero
            for i in range(len(eta)):
                a = abs(rd - eta[i] * k)
                t0 = max(two - a, zero)
                t1 = max(one - a, zero)
                acc += zeta[i] * (spline[0] * (t0 * t0 * t0) + spline[1] * (t1 * t1 * t1))
            out[x] = acc
        return
    half = np.float32(order / 2)
    for x in range(out.shape[0]):
        rd = rho * d_row[x]
        acc = zero
        for i in range(len(eta)):
            a = abs(rd - eta[i] * k)
            for j in range(len(spline)):
                t = max(half - np.float32(j) - a, zero)
                tp = t
                for _ in range(order - 2):
                    tp *= t
                acc += zeta[i] * spline[j] * tp
        out[x] = acc


@njit(**JIT)
def _spline_reaches(d_row, rho, k, eta, order):
    """Whether some |rho D - eta_i K| of the row may be below m/2 (a term non-zero).

    From the row's range of D, found on the bits as int32: they order like the floats
    where D >= 0, and LLVM vectorises integer min/max (float ones it leaves scalar here).
    D is a sum of |dS| but may round below 0: then the row is not skipped. The test has
    a margin far above float32's rounding of rho D - eta_i K.
    """
    bits = d_row.view(np.int32)
    lo = bits[0]
    hi = bits[0]
    for x in range(bits.shape[0]):
        lo = min(lo, bits[x])
        hi = max(hi, bits[x])
    if lo < 0:
        return True
    rd_lo = float(rho) * float(np.int32(lo).view(np.float32))
    rd_hi = float(rho) * float(np.int32(hi).view(np.float32))
    half = order / 2.0
    for i in range(len(eta)):
        c = float(eta[i]) * float(k)
        margin = 1e-5 * (abs(c) + rd_hi + half)
        if rd_hi > c - half - margin and rd_lo < c + half + margin:
            return True
    return False


@njit(**JIT)
def _feedback_frames(frames, prev, pon_hist, poff_hist, s_prev, ds_hist, d, t, k,
                     g1, g2, delay, eta, zeta, spline, order, scalars, want_layers,
                     map_p, map_s, map_d, map_phi, s_sum):
    """One frame of every stream, row-pipelined (see `lgmd_sim.models.kernels`).

    State, per stream: ``prev`` (the last frame), ``pon_hist``/``poff_hist`` (P_on, P_off
    of the last ``delay_taps`` frames; frame u in slot u % taps), ``s_prev`` (S of the
    last frame), ``ds_hist`` (|S(u) - S(u-1)| of the last ``tv_window`` frames, slot
    u % T) and ``d`` (their sum: D of the coming frame). ``t`` is the frame counter, ``k``
    the K of Eq. 19 per stream. Writes the sum of S per stream into ``s_sum`` and, when
    ``want_layers``, the maps.
    """
    n_streams, height, width = frames.shape
    rho, gb1, gb2, alpha, eps1, eps2 = scalars
    f32 = np.float32
    zero = f32(0.0)
    r1 = len(g1) // 2
    r2 = len(g2) // 2
    lag = max(r1, r2)
    n_slots = 2 * lag + 1
    n_taps = len(delay)
    tv_slot = t % ds_hist.shape[1]  # |dS|(t) overwrites |dS|(t - T)
    phi_line = np.empty(width, f32)
    # P_on, P_off and their delayed mixes, padded for the horizontal filters, then those
    # rows filtered horizontally, kept in rings by row % n_slots for the vertical ones.
    # An identity filter (one tap: sigma < 0.18) is skipped: its ring is the padded rows.
    on_rows = np.empty((n_slots, width + 2 * r1), f32)
    off_rows = np.empty((n_slots, width + 2 * r1), f32)
    mon_pad = np.empty(width + 2 * r2, f32)
    moff_pad = np.empty(width + 2 * r2, f32)
    e_on_ring = on_rows if r1 == 0 else np.empty((n_slots, width), f32)
    e_off_ring = off_rows if r1 == 0 else np.empty((n_slots, width), f32)
    i_on_ring = np.empty((n_slots, width), f32)
    i_off_ring = np.empty((n_slots, width), f32)
    e_on = np.empty(width, f32)
    e_off = np.empty(width, f32)
    i_on = np.empty(width, f32)
    i_off = np.empty(width, f32)
    # Sum of S per column, then of the columns in a fixed order: a vectorised running sum
    # would depend on how LLVM unrolled the loop, so results could differ between calls
    # with and without layers, or between a batch and single streams.
    column_sum = np.empty(width)
    for n in range(n_streams):
        kn = k[n]
        column_sum[:] = 0.0
        for y in range(height + lag):
            if y < height:
                slot = y % n_slots
                pon_pad = on_rows[slot]
                poff_pad = off_rows[slot]
                # Eq. 19, from D(t): frames before t only.
                _phi_row(d[n, y], rho, kn, eta, zeta, spline, order, phi_line)
                fr = frames[n, y]
                pv = prev[n, y]
                if want_layers:  # apart: one store less per pixel in the loop below
                    p_map = map_p[n, y]
                    for x in range(width):
                        p_map[x] = f32(fr[x]) - f32(pv[x])
                    map_phi[n, y] = phi_line
                    map_d[n, y] = d[n, y]
                # Eq. 10-12, 15 as a mix sum_j phi(j) P(t - j), j = 1..n_taps, built in
                # passes over the history; the last one reads the oldest slot and refills
                # it with P(t).
                hon = pon_hist[n, (t - 1) % n_taps, y]
                hoff = poff_hist[n, (t - 1) % n_taps, y]
                w = delay[0]
                for x in range(width):
                    p = f32(fr[x]) - f32(pv[x])  # Eq. 5
                    pv[x] = fr[x]
                    ph = phi_line[x]
                    pon = max(p + gb1 * ph, zero)  # Eq. 6
                    poff = max(-(p + gb2 * ph), zero)  # Eq. 7
                    pon_pad[r1 + x] = pon
                    poff_pad[r1 + x] = poff
                    mon_pad[r2 + x] = w * hon[x]
                    moff_pad[r2 + x] = w * hoff[x]
                    if n_taps == 1:
                        hon[x] = pon
                        hoff[x] = poff
                for j in range(1, n_taps):
                    hon = pon_hist[n, (t - 1 - j) % n_taps, y]
                    hoff = poff_hist[n, (t - 1 - j) % n_taps, y]
                    w = delay[j]
                    if j < n_taps - 1:
                        for x in range(width):
                            mon_pad[r2 + x] += w * hon[x]
                            moff_pad[r2 + x] += w * hoff[x]
                    else:
                        for x in range(width):
                            mon_pad[r2 + x] += w * hon[x]
                            moff_pad[r2 + x] += w * hoff[x]
                            hon[x] = pon_pad[r1 + x]
                            hoff[x] = poff_pad[r1 + x]
                if r1 > 0:  # Eq. 8, 14: horizontal half
                    fill_borders(pon_pad, r1, width)
                    fill_borders(poff_pad, r1, width)
                    hconv(pon_pad, g1, e_on_ring[slot])
                    hconv(poff_pad, g1, e_off_ring[slot])
                fill_borders(mon_pad, r2, width)  # Eq. 10, 15: horizontal half
                fill_borders(moff_pad, r2, width)
                hconv(mon_pad, g2, i_on_ring[slot])
                hconv(moff_pad, g2, i_off_ring[slot])
            yc = y - lag
            if yc < 0:
                continue
            # The vertical halves, then Eq. 13, 16, 17 (S) and Eq. 18 (D), the latter as
            # a running sum: D(t + 1) = D(t) + |dS|(t) - |dS|(t - T).
            if r1 == 0:  # the identity: E is P_on, P_off of row yc
                e_on = e_on_ring[yc % n_slots]
                e_off = e_off_ring[yc % n_slots]
            else:
                vconv(e_on_ring, yc, height, g1, e_on)
                vconv(e_off_ring, yc, height, g1, e_off)
            vconv(i_on_ring, yc, height, g2, i_on)
            vconv(i_off_ring, yc, height, g2, i_off)
            s_row = s_prev[n, yc]
            ds_row = ds_hist[n, tv_slot, yc]
            d_row = d[n, yc]
            for x in range(width):
                s = eps1 * max(e_on[x] - alpha * i_on[x], zero) + eps2 * max(
                    e_off[x] - alpha * i_off[x], zero)
                ds = abs(s - s_row[x])
                d_row[x] += ds - ds_row[x]
                ds_row[x] = ds
                s_row[x] = s
            for x in range(width):  # float64: apart, so the loop above stays 8 wide
                column_sum[x] += s_row[x]
            if want_layers:
                map_s[n, yc] = s_row
        s_sum[n] = ordered_sum(column_sum)
