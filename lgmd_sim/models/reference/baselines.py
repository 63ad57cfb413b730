"""Straightforward per-equation float64 versions of the four baselines: the test oracle.

Each class subclasses the fast model (same name, parameters, presets and interface) and
replaces its three hooks with whole-frame NumPy/OpenCV arithmetic, one equation per line,
one stream at a time, for every value of every switch. These are the speed baseline of
the benchmark, too. (`lgmd_sim.models.reference.published` holds ports of the published
code itself, the oracles of the ``published`` presets.)
"""

from __future__ import annotations

import cv2
import numpy as np

from lgmd_sim.models.baseline import BaselineParams
from lgmd_sim.models.ffi import FOffLGMD, FOnLGMD
from lgmd_sim.models.lgmd1 import LGMD1
from lgmd_sim.models.lgmd2 import LGMD2

__all__ = ["FOffReference", "FOnReference", "LGMD1Reference", "LGMD2Reference"]

_BOX = np.full((3, 3), 1.0 / 9.0)
_BORDERS = {"replicate": cv2.BORDER_REPLICATE, "reflect": cv2.BORDER_REFLECT_101,
            "zero": cv2.BORDER_CONSTANT, "interior": cv2.BORDER_REFLECT_101}


def _conv(a: np.ndarray, kernel: np.ndarray, border: str) -> np.ndarray:
    return cv2.filter2D(a, cv2.CV_64F, kernel, borderType=_BORDERS[border])


def _kernel(centre: float, near: float, diagonal: float) -> np.ndarray:
    return np.array([[diagonal, near, diagonal], [near, centre, near], [diagonal, near, diagonal]])


def _sigmoid(x: float) -> float:
    return min(1.0 / (1.0 + np.exp(-x)), np.nextafter(1.0, 0.0))


def _g_layer(s: np.ndarray, p: BaselineParams) -> np.ndarray:
    """G = S Ce / w, w = delta_c + max|Ce| / c_w, zeroed where G c_de < t_de."""
    ce = _conv(s, _BOX, p.border)
    w = p.delta_c + np.abs(ce).max() / p.c_w
    g = s * ce / w
    g[g * p.c_de < p.t_de] = 0.0
    return g


def _interior(s: np.ndarray, p: BaselineParams) -> np.ndarray:
    """S with its 1-pixel frame border zeroed, for border 'interior'."""
    if p.border == "interior":
        s = s.copy()
        s[[0, -1], :] = 0.0
        s[:, [0, -1]] = 0.0
    return s


def _persistence(p: BaselineParams, k: int) -> tuple[float, float]:
    """(c1, c2) of P = L(t) - L(t-1) + c1 P(t-1) + c2 P(t-2) at a stream's frame k."""
    if p.persistence == "constant":
        return p.persistence_weights
    if p.persistence == "decaying":
        return 1.0 / (1.0 + np.exp(k)), 1.0 / (1.0 + np.exp(k - 1.0))
    return 0.0, 0.0


class _PerStream:
    """Per-stream state as a dict, created on a stream's first frame."""

    def allocate(self, n: int, height: int, width: int) -> None:
        self._state: list[dict | None] = [None] * n

    def reset_streams(self, idx: np.ndarray) -> None:
        for i in idx:
            self._state[i] = None

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        out = np.empty(len(grey))
        for i, frame in enumerate(grey):
            maps = {}
            out[i] = self._frame(i, frame.astype(np.float64), maps)
            if layers is not None:
                for k in layers:
                    layers[k][i] = maps[k]
        return out


class LGMD1Reference(_PerStream, LGMD1):
    """LGMD1, per equation."""

    def _frame(self, i: int, frame: np.ndarray, maps: dict) -> float:
        p = self.params
        st = self._state[i]
        if st is None:
            z = np.zeros_like(frame)
            st = self._state[i] = {"L": frame, "E": z, "P2": z, "mean_abs_p": 0.0, "k": 0}
        c1, c2 = _persistence(p, st["k"])
        P = frame - st["L"] + c1 * st["E"] + c2 * st["P2"]
        E = P
        I = _conv(st["E"], _kernel(0.0, p.inhibition_near, p.inhibition_diagonal), p.border)  # noqa: E741
        S = E - p.w_i * I
        if p.t_s is not None:
            S[(S if p.t_s_rule == "signed" else np.abs(S)) < p.t_s] = 0.0
        if p.coincidence:
            S[E * I <= 0] = 0.0
        S = _interior(S, p)
        if p.g_layer:
            G = _g_layer(S, p)
            total = np.abs(G).sum()
        else:
            G = np.zeros_like(S)
            total = S.sum()
        K = _sigmoid(total / (S.size * p.c_sig))
        if p.t_ffi is not None and st["mean_abs_p"] >= p.t_ffi:  # FFI from P(t-1)
            K = 0.5
        st.update(L=frame, E=E, P2=st["E"], mean_abs_p=np.abs(P).mean(), k=st["k"] + 1)
        maps.update(P=P, S=S, G=G)
        return K


class _OnOffReference(_PerStream):
    """LGMD2 and the F(ON)/F(OFF) LGMDs, per equation."""

    def _frame(self, i: int, frame: np.ndarray, maps: dict) -> float:
        p = self.params
        if p.dt is not None:
            dt = p.dt
        else:
            dt = 1000.0 // p.fps if p.dt_integer else 1000.0 / p.fps

        def alpha(tau: float) -> float:
            return dt / (dt + tau)

        st = self._state[i]
        if st is None:
            z = np.zeros_like(frame)
            st = self._state[i] = {
                "L": frame, "P1": z, "P2": z, "ON": z, "OFF": z, "lp_on": [z] * 3,
                "lp_off": [z] * 3, "m": np.zeros(3), "PM": np.zeros(3), "AIM": 0.0,
                "h": (1.0, 1.0), "K": 0.5, "A": 0.5, "k": 0,
            }
        c1, c2 = _persistence(p, st["k"])
        P = frame - st["L"] + c1 * st["P1"] + c2 * st["P2"]
        ON = np.maximum(P, 0.0) + p.carry * st["ON"]
        OFF = np.maximum(-P, 0.0) + p.carry * st["OFF"]
        # PM: means of |P|, ON, OFF, filtered
        m = np.array([np.abs(P).mean(), ON.mean(), OFF.mean()])
        current = m.copy()
        if p.pm_off_uses_on_mean:
            current[2] = m[1]
        a_pm = alpha(p.tau_pm)
        if p.pm_filter == "two-tap":
            PM = a_pm * current + (1 - a_pm) * st["m"]
        else:
            PM = st["PM"] + a_pm * (current - st["PM"])
        per_channel = p.pm_weights == "per-channel"
        W_on = max(p.w_on_min, PM[1 if per_channel else 0] / p.t_pm)
        W_off = max(p.w_off_min, PM[2 if per_channel else 0] / p.t_pm)
        # feed-forward gates, and what a gated channel feeds to inhibition (E)
        gate_on = p.ffi_channels not in ("on", "both") or PM[1] >= p.ffi_gate
        gate_off = p.ffi_channels not in ("off", "both") or PM[2] >= p.ffi_gate
        h = (float(gate_on), float(gate_off)) if p.ffi_gates_history else (1.0, 1.0)
        h_prev = st["h"]
        # I: the delayed copies under the centre, near and diagonal kernels
        if p.inhibition_filter == "two-frame":  # a E(t) + (1 - a) E(t-1)
            d_on = [alpha(tau) * h[0] * ON + (1 - alpha(tau)) * h_prev[0] * st["ON"]
                    for tau in p.on_delays]
            d_off = [alpha(tau) * h[1] * OFF + (1 - alpha(tau)) * h_prev[1] * st["OFF"]
                     for tau in p.off_delays]
        else:  # low-passes of the previous frames
            d_on, d_off = st["lp_on"], st["lp_off"]
        c, n, d = p.on_weights
        kernels_on = (_kernel(c, 0, 0), _kernel(0, n, 0), _kernel(0, 0, d))
        c, n, d = p.off_weights
        kernels_off = (_kernel(c, 0, 0), _kernel(0, n, 0), _kernel(0, 0, d))
        I_on = sum(_conv(x, k, p.border) for x, k in zip(d_on, kernels_on, strict=True))
        I_off = sum(_conv(x, k, p.border) for x, k in zip(d_off, kernels_off, strict=True))
        S_on = np.maximum(ON - W_on * I_on, 0.0) if gate_on else np.zeros_like(ON)
        S_off = np.maximum(OFF - W_off * I_off, 0.0) if gate_off else np.zeros_like(OFF)
        S = _interior(S_on + S_off + p.onoff_product * S_on * S_off, p)
        G = _g_layer(S, p)
        K = _sigmoid(G.sum() / (G.size * p.c_sig))
        AIM = PM[1] + PM[2]
        if p.global_ffi_base is not None and AIM >= p.global_ffi_base + (
            p.global_ffi_gain * st["AIM"]
        ):
            K = 0.5
        # SFA
        a_sfa = p.tau_sfa / (p.tau_sfa + dt)
        dK = K - st["K"]
        if dK <= p.t_sfa:
            A = a_sfa * (st["A"] + dK)
        else:
            A = K if p.sfa_rise == "follow" else a_sfa * K
        A = max(A, 0.5)
        st.update(
            L=frame, P1=P, P2=st["P1"], ON=ON, OFF=OFF, m=m, PM=PM, AIM=AIM, h=h, K=K, A=A,
            k=st["k"] + 1,
            lp_on=[lp + alpha(tau) * (h[0] * ON - lp)
                   for lp, tau in zip(st["lp_on"], p.on_delays, strict=True)],
            lp_off=[lp + alpha(tau) * (h[1] * OFF - lp)
                    for lp, tau in zip(st["lp_off"], p.off_delays, strict=True)],
        )
        maps.update(P=P, ON=ON, OFF=OFF, S=S, G=G)
        return A


class LGMD2Reference(_OnOffReference, LGMD2):
    """LGMD2, per equation."""


class FOnReference(_OnOffReference, FOnLGMD):
    """F(ONn)-LGMD, per equation."""


class FOffReference(_OnOffReference, FOffLGMD):
    """F(OFFp)-LGMD, per equation."""
