"""The feedback LGMD written equation by equation in float64: the test oracle.

One function per equation of the paper (Sec. 3), on whole frames, with explicit
histories (lists of past frames) and OpenCV/NumPy filters. It shares the parameters,
presets and interface of `lgmd_sim.models.feedback.FeedbackLGMD`, whose fused float32
kernel must agree with it; its speed is the baseline of ``lgmd-sim bench models``.
Independent where it can be: the B-spline by the Cox-de Boor recursion (Eq. 1-2), the
Gaussian taps by OpenCV (untrimmed), D summed afresh every frame (no running sum).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from lgmd_sim.models.feedback import FeedbackLGMD, FeedbackParams

__all__ = [
    "FeedbackReference",
    "cardinal_bspline",
    "delay_filter",
    "excitation",
    "feedback",
    "inhibition",
    "membrane_potential",
    "photoreceptor",
    "rectify_off",
    "rectify_on",
    "summation",
    "summation_channel",
    "total_variation",
]


def photoreceptor(frame: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
    """Eq. 5: P(t) = L(t) - L(t - 1); 0 on the first frame of a stream."""
    return np.zeros_like(frame) if previous is None else frame - previous


def rectify_on(p: np.ndarray, phi: np.ndarray, beta1: float) -> np.ndarray:
    """Eq. 6: P_on = [P + beta1 Phi]^+."""
    return np.maximum(p + beta1 * phi, 0.0)


def rectify_off(p: np.ndarray, phi: np.ndarray, beta2: float) -> np.ndarray:
    """Eq. 7: P_off = [P + beta2 Phi]^- = max(-(P + beta2 Phi), 0)."""
    return np.maximum(-(p + beta2 * phi), 0.0)


def gaussian(image: np.ndarray, sigma: float) -> np.ndarray:
    """Eq. 8-9: a sampled, normalised Gaussian, radius max(1, ceil(3 sigma)), replicate borders."""
    size = 2 * max(1, math.ceil(3.0 * sigma)) + 1
    g = cv2.getGaussianKernel(size, sigma, cv2.CV_64F)
    return cv2.sepFilter2D(image, cv2.CV_64F, g, g, borderType=cv2.BORDER_REPLICATE)


def excitation(p_channel: np.ndarray, sigma1: float) -> np.ndarray:
    """Eq. 8, 14: E = P_on/off blurred by G_sigma1."""
    return gaussian(p_channel, sigma1)


def delay_filter(n_taps: int) -> np.ndarray:
    """Eq. 11-12 on frames: phi(j) = 2 exp(-pi j^2) for delays j = 1..n_taps, normalised."""
    w = np.array([2.0 * math.exp(-math.pi * j * j) for j in range(1, n_taps + 1)])
    return w / w.sum()


def inhibition(history: list[np.ndarray], weights: np.ndarray, sigma2: float) -> np.ndarray:
    """Eq. 10, 15: I = G_sigma2 * sum_j phi(j) P_on/off(t - j); history[0] is frame t - 1."""
    return gaussian(sum(w * h for w, h in zip(weights, history, strict=True)), sigma2)


def summation_channel(e: np.ndarray, i: np.ndarray, alpha: float) -> np.ndarray:
    """Eq. 13, 16: S_on/off = [E - alpha I]^+."""
    return np.maximum(e - alpha * i, 0.0)


def summation(s_on: np.ndarray, s_off: np.ndarray, eps1: float, eps2: float) -> np.ndarray:
    """Eq. 17: S = eps1 S_on + eps2 S_off."""
    return eps1 * s_on + eps2 * s_off


def total_variation(s_history: list[np.ndarray]) -> np.ndarray:
    """Eq. 18: D(t) = sum_{s=1..T} |S(t - s) - S(t - s - 1)|; s_history[0] is S(t - 1)."""
    return sum(np.abs(a - b) for a, b in itertools.pairwise(s_history))


def cardinal_bspline(x: np.ndarray, m: int) -> np.ndarray:
    """Eq. 1-2: the cardinal B-spline N_m (support [0, m]), by the Cox-de Boor recursion."""
    if m == 1:
        return ((x >= 0.0) & (x < 1.0)).astype(np.float64)
    return (x * cardinal_bspline(x, m - 1) + (m - x) * cardinal_bspline(x - 1.0, m - 1)) / (m - 1)


def feedback(d: np.ndarray, p: FeedbackParams, k: float) -> np.ndarray:
    """Eq. 19 (with Eq. 3's radial form): Phi = sum_i zeta_i N_m(|rho D - eta_i K| + m/2)."""
    m = p.spline_order
    return sum(
        zeta * cardinal_bspline(np.abs(p.rho * d - eta * k) + m / 2.0, m)
        for eta, zeta in zip(p.eta, p.zeta, strict=True)
    )


def membrane_potential(s: np.ndarray, mu: float) -> float:
    """Eq. 20: K = 1 / (1 + exp(-sum S / (R C mu)))."""
    return 1.0 / (1.0 + math.exp(-float(s.sum()) / (s.size * mu)))


@dataclass
class _Stream:
    """One stream's history: newest first."""

    shape: tuple[int, int]
    n_taps: int
    window: int
    previous: np.ndarray | None = None
    potential: float = 0.5
    on: list[np.ndarray] = field(default_factory=list)
    off: list[np.ndarray] = field(default_factory=list)
    s: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.on = [np.zeros(self.shape) for _ in range(self.n_taps)]  # P_on(t - 1 ... t - n)
        self.off = [np.zeros(self.shape) for _ in range(self.n_taps)]
        self.s = [np.zeros(self.shape) for _ in range(self.window + 1)]  # S(t - 1 ... t - T - 1)


class FeedbackReference(FeedbackLGMD):
    """Per-equation float64 feedback LGMD (same parameters and interface as `FeedbackLGMD`)."""

    def allocate(self, n: int, height: int, width: int) -> None:
        self._streams: list[_Stream] = []
        self._shape = (height, width)

    def reset_streams(self, idx: np.ndarray) -> None:
        p = self.params
        fresh = {int(i): _Stream(self._shape, p.delay_taps, p.tv_window) for i in idx}
        self._streams = [fresh.get(i) or self._streams[i] for i in range(self._n)]

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        return np.array([self._step_stream(i, grey[i], layers) for i in range(self._n)])

    def _step_stream(self, i: int, frame: np.ndarray, layers: dict | None) -> float:
        p = self.params
        st = self._streams[i]
        lum = frame.astype(np.float64)
        k = st.potential if p.k_mode == "potential" else float(p.k)
        d = total_variation(st.s)
        phi = feedback(d, p, k)
        pp = photoreceptor(lum, st.previous)
        p_on = rectify_on(pp, phi, p.feedback_gain * p.beta1)
        p_off = rectify_off(pp, phi, p.feedback_gain * p.beta2)
        weights = delay_filter(p.delay_taps)
        s_on = summation_channel(excitation(p_on, p.sigma1),
                                 inhibition(st.on, weights, p.sigma2), p.alpha)
        s_off = summation_channel(excitation(p_off, p.sigma1),
                                  inhibition(st.off, weights, p.sigma2), p.alpha)
        s = summation(s_on, s_off, p.eps1, p.eps2)
        st.potential = membrane_potential(s, p.mu)
        st.previous = lum
        st.on = [p_on, *st.on[:-1]]
        st.off = [p_off, *st.off[:-1]]
        st.s = [s, *st.s[:-1]]
        if layers is not None:
            for name, image in (("P", pp), ("S", s), ("D", d), ("Phi", phi)):
                layers[name][i] = image
        return st.potential
