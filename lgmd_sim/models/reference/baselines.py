"""Straightforward per-equation float64 versions of the four baselines: the test oracle.

Each class subclasses the fast model (same name, parameters and interface) and replaces
its three hooks with whole-frame NumPy/OpenCV arithmetic, one equation per line, one
stream at a time. Borders are replicated, as in the fast kernels. These are the speed
baseline of the benchmark, too.
"""

from __future__ import annotations

import cv2
import numpy as np

from lgmd_sim.models.ffi import FOffLGMD, FOnLGMD
from lgmd_sim.models.lgmd1 import LGMD1, GLayerParams
from lgmd_sim.models.lgmd2 import LGMD2

__all__ = ["FOffReference", "FOnReference", "LGMD1Reference", "LGMD2Reference"]

_BOX = np.full((3, 3), 1.0 / 9.0)


def _conv(a: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    return cv2.filter2D(a, cv2.CV_64F, kernel, borderType=cv2.BORDER_REPLICATE)


def _kernel(centre: float, near: float, diagonal: float) -> np.ndarray:
    return np.array([[diagonal, near, diagonal], [near, centre, near], [diagonal, near, diagonal]])


def _sigmoid(x: float) -> float:
    return min(1.0 / (1.0 + np.exp(-x)), np.nextafter(1.0, 0.0))


def _g_layer(s: np.ndarray, p: GLayerParams) -> np.ndarray:
    """G = S Ce / w, w = delta_c + max|Ce| / c_w, zeroed where G c_de < t_de."""
    ce = _conv(s, _BOX)
    w = p.delta_c + np.abs(ce).max() / p.c_w
    g = s * ce / w
    g[g * p.c_de < p.t_de] = 0.0
    return g


class _PerStream:
    """Per-stream state as a dict, created on a stream's first frame."""

    def _allocate(self, n: int, height: int, width: int) -> None:
        self._state: list[dict | None] = [None] * n

    def _reset_streams(self, idx: np.ndarray) -> None:
        for i in idx:
            self._state[i] = None

    def _step(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
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
            st = self._state[i] = {"L": frame, "E": np.zeros_like(frame), "mean_abs_p": 0.0}
        P = frame - st["L"]
        E = P
        I = _conv(st["E"], _kernel(0.0, p.inhibition_near, p.inhibition_diagonal))  # noqa: E741
        S = E - p.w_i * I
        S[np.abs(S) < p.t_s] = 0.0
        if p.coincidence:
            S[E * I <= 0] = 0.0
        G = _g_layer(S, p)
        K = _sigmoid(np.abs(G).sum() / (G.size * p.c_sig))
        if st["mean_abs_p"] >= p.t_ffi:  # FFI from P(t-1)
            K = 0.5
        st.update(L=frame, E=E, mean_abs_p=np.abs(P).mean())
        maps.update(P=P, S=S, G=G)
        return K


class _OnOffReference(_PerStream):
    """LGMD2 and the F(ON)/F(OFF) LGMDs, per equation."""

    def _frame(self, i: int, frame: np.ndarray, maps: dict) -> float:
        p = self.params
        dt = 1000.0 / p.fps

        def alpha(tau: float) -> float:
            return dt / (dt + tau)

        st = self._state[i]
        if st is None:
            z = np.zeros_like(frame)
            st = self._state[i] = {
                "L": frame, "ON": z, "OFF": z, "lp_on": [z] * 3, "lp_off": [z] * 3,
                "PM": 0.0, "PM_on": 0.0, "PM_off": 0.0, "K": 0.5, "A": 0.5,
            }
        P = frame - st["L"]
        ON = np.maximum(P, 0.0) + p.carry * st["ON"]
        OFF = np.maximum(-P, 0.0) + p.carry * st["OFF"]
        a_pm = alpha(p.tau_pm)
        PM = st["PM"] + a_pm * (np.abs(P).mean() - st["PM"])
        PM_on = st["PM_on"] + a_pm * (ON.mean() - st["PM_on"])
        PM_off = st["PM_off"] + a_pm * (OFF.mean() - st["PM_off"])
        W_on = max(p.w_on_min, PM / p.t_pm)
        W_off = max(p.w_off_min, PM / p.t_pm)
        # I from the low-passes of earlier frames: centre, near, diagonal delays
        c, n, d = p.on_weights
        kernels_on = (_kernel(c, 0, 0), _kernel(0, n, 0), _kernel(0, 0, d))
        c, n, d = p.off_weights
        kernels_off = (_kernel(c, 0, 0), _kernel(0, n, 0), _kernel(0, 0, d))
        I_on = sum(_conv(lp, k) for lp, k in zip(st["lp_on"], kernels_on, strict=True))
        I_off = sum(_conv(lp, k) for lp, k in zip(st["lp_off"], kernels_off, strict=True))
        S_on = np.maximum(ON - W_on * I_on, 0.0)
        S_off = np.maximum(OFF - W_off * I_off, 0.0)
        channel = getattr(self, "ffi_channel", None)
        if channel == "on" and PM_on < p.ffi_gate:
            S_on = np.zeros_like(S_on)
        if channel == "off" and PM_off < p.ffi_gate:
            S_off = np.zeros_like(S_off)
        S = S_on + S_off + S_on * S_off
        G = _g_layer(S, p)
        K = _sigmoid(G.sum() / (G.size * p.c_sig))
        # SFA
        a_sfa = p.tau_sfa / (p.tau_sfa + dt)
        dK = K - st["K"]
        A = a_sfa * (st["A"] + dK) if dK <= p.t_sfa else K
        A = max(A, 0.5)
        st.update(
            L=frame, ON=ON, OFF=OFF, PM=PM, PM_on=PM_on, PM_off=PM_off, K=K, A=A,
            lp_on=[lp + alpha(tau) * (ON - lp) for lp, tau in zip(st["lp_on"], p.on_delays,
                                                                   strict=True)],
            lp_off=[lp + alpha(tau) * (OFF - lp) for lp, tau in zip(st["lp_off"], p.off_delays,
                                                                     strict=True)],
        )
        maps.update(P=P, ON=ON, OFF=OFF, S=S, G=G)
        return A


class LGMD2Reference(_OnOffReference, LGMD2):
    """LGMD2, per equation."""


class FOnReference(_OnOffReference, FOnLGMD):
    """F(ONn)-LGMD, per equation."""


class FOffReference(_OnOffReference, FOffLGMD):
    """F(OFFp)-LGMD, per equation."""
