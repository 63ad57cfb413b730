"""Readable NumPy ports of the published baseline implementations: the oracles of the
``published`` presets.

Each function follows one published file, statement by statement but in whole-frame
NumPy/OpenCV and in our own words, and keeps that file's own structure (its loop, its
state, its constants written out), independent of this package's models: the tests check
that the fast models with the matching preset agree with it. Comments name the method or
statement followed. Files read (repository, path, commit):

- PI-LGMD: XuelongSun/InsectInspiredNavigation_PI-LGMD, simulations/models.py,
  176e0972a69e051a0614f8ab36f3e8d72a4fe4eb (LobulaGiantMotionDetectorModel.run).
- LGMDSingle: fuqinbing/LGMD-Plus-and-GAs-Open-Source, code/LGMDSingle.cs,
  0dacd1f70b654aa6ad0ab1e63c960bafe0c15187 (LGMDSProcessing).
- pLGMD: fuqinbing/pLGMD, LGMD.m, 7158bb313e2da779f6143cfce9085751e4666577.
- LGMD2: fuqinbing/LGMD2-open-source, lgmd2OpenSource.cs,
  11e4be5915ff4e1a40ec36eae6b7c4eb19e6b892 (the same code at 4fb239d0...; LGMD2_Processing).
- oLGMD: Ryannnice/Supplementary_Materials_FFI_ON_OFF,
  Core_of_Source_Code/Computer_oLGMD_Python/optimized_LGMD.py,
  dca30975f0600cec3c1e9a3e90bac96f2f6a4d7b (LGMD2.LGMD).

Conventions, so that index t here is frame t of a stream in `lgmd_sim.models`:

- ``frames`` is (T, H, W) grey levels 0..255 (what the published code reads after its own
  colour conversion; the ports take grey frames). Each function returns T potentials;
  element 0 is 0.5, the stream's first frame, which has no predecessor.
- The C# classes are called with two consecutive frames, so their first call is on
  (frames[0], frames[1]). pLGMD's loop starts at t = 3 (MATLAB) and the oLGMD's at t = 2,
  with P = 0 before: neither uses its clip's very first frame, so frames[0] here plays
  their In(2) and Z[1].
- Arithmetic is float64 throughout (the C# code computes in float32, the ports in float64;
  the differences are far below the tests' 1e-4).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["ORACLES", "lgmd2_open_source", "lgmd_single", "olgmd", "pi_lgmd", "plgmd"]

_REFLECT = cv2.BORDER_REFLECT_101  # cv2.filter2D's default border
_CLAMP = cv2.BORDER_REPLICATE  # the C# loops: while (r < 0) r += 1; ...
_ZERO = cv2.BORDER_CONSTANT  # MATLAB conv2(..., 'same')


def _filter(a: np.ndarray, kernel: np.ndarray, border: int) -> np.ndarray:
    """3x3 correlation (the kernels are symmetric, so also convolution)."""
    return cv2.filter2D(a, cv2.CV_64F, np.asarray(kernel, np.float64), borderType=border)


def _kernel(centre: float, near: float, diagonal: float) -> np.ndarray:
    return np.array([[diagonal, near, diagonal], [near, centre, near],
                     [diagonal, near, diagonal]])


def _grey(frames: np.ndarray) -> np.ndarray:
    return np.asarray(frames, np.float64)


# --- LGMD1 ------------------------------------------------------------------------------


def pi_lgmd(frames: np.ndarray) -> np.ndarray:
    """LobulaGiantMotionDetectorModel.run of PI-LGMD's models.py (defaults of __init__)."""
    z = _grey(frames)
    i_w, c_de, thr_de = 0.4, 0.5, 15  # self.i_w, self.Cde, self.thr_de
    wi = _kernel(0.0, 0.25, 0.125)  # self.Wi
    we = np.ones((3, 3)) / 9.0  # self.We
    p_prev = np.zeros_like(z[0])  # self.p[0]
    k = [0.5]
    for t in range(1, len(z)):
        p = z[t] - z[t - 1]  # self.p[1] = frame[1] - frame[0]; self.e = p[1]
        i = _filter(p_prev, wi, _REFLECT)  # cv2.filter2D(self.p[0], -1, self.Wi)
        s = p - i * i_w
        ce = _filter(s, we, _REFLECT)
        w = 0.01 + np.max(np.abs(ce / 4.0))
        g = s * ce / w
        g[g * c_de < thr_de] = 0
        k.append(1.0 / (1.0 + math.exp(-np.sum(g) / p.size)))
        # the FFI (signed mean of p[0] against ffi_thr) only gates self.ffi_spikes
        p_prev = p  # self.p[0] = self.p[1]
    return np.array(k)


def lgmd_single(frames: np.ndarray) -> np.ndarray:
    """LGMDSProcessing of LGMDSingle.cs (constructor values: Wi 0.6, Ts 30, Tffi 10, Csig 1)."""
    z = _grey(frames)
    wi, ts, tffi, csig = 0.6, 30, 10, 1.0
    kernel = _kernel(0.0, 0.25, 0.125)  # localIW
    e_prev = np.zeros_like(z[0])  # Excitations[.., pre_frame]
    n_cell = z[0].size
    k = [0.5]
    for t in range(1, len(z)):
        e = z[t] - z[t - 1]  # pcellValue; Excitations[.., cur_frame] = Photoreceptors
        ffi = np.abs(e_prev).mean()  # tmp_ffi over Excitations[.., pre_frame] / Ncell
        if ffi >= tffi:
            mp = 0.0  # "min value"
        else:
            i = _filter(e_prev, kernel, _CLAMP)  # icellValue
            s = e - i * wi
            s = np.where((e * i <= 0) | (s < ts), 0.0, s)  # scellValue
            mp = s.sum()
        k.append(1.0 / (1.0 + math.exp(-mp / (n_cell * csig))))  # Sigmoid
        e_prev = e
    return np.array(k)


def plgmd(frames: np.ndarray) -> np.ndarray:
    """LGMD.m of pLGMD with its defaults (Cde 0.15, Tde 15, WI 0.3, p1 = p2 = 0.5, Cw 4)."""
    z = _grey(frames)
    cde, tde, wi_, cw = 0.15, 15, 0.3, 4
    p1 = p2 = 1.0 / (1.0 + math.exp(0.0))
    w = _kernel(0.0, 0.25, 0.125)
    we = np.ones((3, 3)) / 9.0
    p_1 = np.zeros_like(z[0])  # P(:,:,t-1)
    p_2 = np.zeros_like(z[0])  # P(:,:,t-2)
    k = [0.5]
    for t in range(1, len(z)):
        p = z[t] - z[t - 1] + p1 * p_1 + p2 * p_2  # P layer, with luminance persistence
        e = p  # E layer
        i = _filter(p_1, w, _ZERO)  # conv2(P(:,:,t-1), w, 'same')
        s = e - i * wi_  # SUM
        ce = _filter(s, we, _ZERO)
        omega = np.max(np.abs(ce)) / cw + 0.01
        g = s * ce / omega
        g_ = g * (g * cde >= tde)
        k.append(1.0 / (1.0 + math.exp(-np.sum(np.abs(g_)) / p.size)))
        p_2, p_1 = p_1, p
    return np.array(k)


# --- LGMD2 ------------------------------------------------------------------------------


def lgmd2_open_source(frames: np.ndarray, fps: int = 30) -> np.ndarray:
    """LGMD2_Processing of lgmd2OpenSource.cs, built with ``fps`` (constructor values)."""
    z = _grey(frames)
    time_interval = float(1000 // fps)  # 1000 / fps: C# integer division
    lp_on = [time_interval / (time_interval + tau) for tau in (15, 30, 45)]  # tau_ON
    lp_off = [time_interval / (time_interval + tau) for tau in (60, 120, 180)]  # tau_OFF
    lp_pm = time_interval / (time_interval + 90)  # tau_PM
    hp_sfa = 800 / (800 + time_interval)  # tau_sfa
    dc, clip_point, tpm, w_on_base, w_off_base = 0.1, 0.1, 8, 1.0, 0.5
    cw, delta_c, cde, tde, csig, tsfa = 4, 0.01, 0.5, 15, 1.0, 0.003
    w_on = w_off = w_onoff = 1.0
    conv_on = [_kernel(2, 0, 0), _kernel(0, 0.5, 0), _kernel(0, 0, 0.25)]  # makeONConvKernel
    conv_off = [_kernel(1, 0, 0), _kernel(0, 0.25, 0), _kernel(0, 0, 0.125)]
    n_cell = z[0].size
    # the arrays' initial zeros: ons/offs, pm, smp and sfa of the "previous frame"
    ons = np.zeros_like(z[0])
    offs = np.zeros_like(z[0])
    pm = smp = sfa = 0.0
    out = [0.5]
    for t in range(1, len(z)):
        p = z[t] - z[t - 1]  # HighpassFilter
        pm = lp_pm * np.abs(p).mean() + (1 - lp_pm) * pm  # LowpassFilter(pm, pm(t-1))
        wi_on = max(pm / tpm, w_on_base)
        wi_off = max(pm / tpm, w_off_base)
        on = np.where(p >= clip_point, p, 0.0) + dc * ons  # HRplusDC_ON
        off = np.where(p < clip_point, np.abs(p), 0.0) + dc * offs  # HRplusDC_OFF
        # Convolution(): each cell of the 3x3 kernel takes LowpassFilter(cur, pre, lp[k])
        inh_on = sum(_filter(a * on + (1 - a) * ons, k, _CLAMP)
                     for a, k in zip(lp_on, conv_on, strict=True))
        inh_off = sum(_filter(a * off + (1 - a) * offs, k, _CLAMP)
                      for a, k in zip(lp_off, conv_off, strict=True))
        s_on = np.maximum(on - inh_on * wi_on, 0.0)  # sCellValue: tmp <= 0 gives 0
        s_off = np.maximum(off - inh_off * wi_off, 0.0)
        s = w_on * s_on + w_off * s_off + w_onoff * s_on * s_off  # SupralinearSummation
        ce = _filter(s, np.ones((3, 3)) / 9.0, _CLAMP)  # Convolving(scells, W_g)
        scale = delta_c + np.max(np.abs(ce)) / cw  # Scale
        g = s * ce / scale
        g = np.where(g * cde >= tde, g, 0.0)  # gCellValue
        smp_now = 1.0 / (1.0 + math.exp(-g.sum() / (n_cell * csig)))  # SigmoidTransfer
        diff = smp_now - smp  # SFA_HPF(sfa[pre], smp[pre], smp[cur])
        sfa = hp_sfa * (sfa + diff) if diff <= tsfa else hp_sfa * smp_now
        sfa = max(sfa, 0.5)
        smp = smp_now
        ons, offs = on, off
        out.append(sfa)
    return np.array(out)


def olgmd(frames: np.ndarray, *, pm_off_from_on_mean: bool = True) -> np.ndarray:
    """LGMD2.LGMD of optimized_LGMD.py: the oLGMD, K after its SFA (``self.K``).

    ``pm_off_from_on_mean`` True is the file as written: PM_ff = a4 * pmon + (1 - a4) *
    pff0 takes the ON mean; False takes the OFF mean (pmff).
    """
    z = _grey(frames)
    w3, w4, tpm, a1 = 1.0, 0.3, 6.0, 0.1
    dt = 53.0  # self.t
    t1, t2, t3, t4, t5, t6 = 45.0, 30.0, 15.0, 180.0, 120.0, 60.0
    a4 = dt / (10 + dt)
    a5 = 0.6
    a6 = 800 / (800 + dt)
    o1, o2, o3 = 1.0, 1.0, 0.0
    oon = ooff = 1.15
    cde, tde, tsfa = 0.5, 15.0, 0.002

    def temporal(diag: float, near: float, centre: float) -> np.ndarray:  # a2, a3
        return np.array([[diag, near, diag], [near, centre, near], [diag, near, diag]])

    a2 = temporal(dt / (dt + t1), dt / (dt + t2), dt / (dt + t3))
    a3 = temporal(dt / (dt + t4), dt / (dt + t5), dt / (dt + t6))
    w1_kernel = _kernel(2, 0.5, 0.25)
    w2_kernel = _kernel(1, 0.25, 0.125)
    wg = np.ones((3, 3)) / 9.0

    def inhibited(e: np.ndarray, e_prev: np.ndarray, a: np.ndarray, kernel: np.ndarray,
                  weight: float) -> np.ndarray:
        """max(E - weight I, 0) on the interior cells 1..H-2 x 1..W-2, 0 on the border;
        I sums kernel * (a E(t) + (1 - a) E(t-1)) over the 3x3 neighbourhood."""
        h, w = e.shape
        inh = np.zeros((h - 2, w - 2))
        for dy in range(3):
            for dx in range(3):
                cur = e[dy:h - 2 + dy, dx:w - 2 + dx]
                pre = e_prev[dy:h - 2 + dy, dx:w - 2 + dx]
                inh += (cur * a[dy, dx] + pre * (1 - a[dy, dx])) * kernel[dy, dx]
        s = np.zeros_like(e)
        s[1:-1, 1:-1] = np.maximum(e[1:-1, 1:-1] - inh * weight, 0.0)
        return s

    zeros = np.zeros_like(z[0])
    p_1 = p_2 = pon_prev = pff_prev = eon_prev = eff_prev = zeros
    pon0 = pff0 = 0.0
    aim_prev = 0.0  # self.AIM[t-1]
    k1 = k_pre = 0.0
    n = z[0].size
    out = [0.5]  # self.K.append(0.5)
    for s_idx in range(1, len(z)):
        t = s_idx + 1  # the file's loop index: frames[0] is its Z[1]
        a11 = 1 / (1 + np.exp(t - 1))
        a12 = 1 / (1 + np.exp(t - 2))
        p = z[s_idx] - z[s_idx - 1] + a11 * p_1 + a12 * p_2
        pon = p * (p > 0) + a1 * pon_prev  # half-wave rectify (0.1 written out)
        pff = np.abs(p * (p < 0)) + a1 * pff_prev
        pmon = np.abs(pon).sum() / n
        pmff = np.abs(pff).sum() / n
        pm_on = a4 * pmon + (1 - a4) * pon0
        pm_ff = a4 * (pmon if pm_off_from_on_mean else pmff) + (1 - a4) * pff0
        w1 = pm_on / tpm if pm_on / tpm > w3 else w3
        w2 = pm_ff / tpm if pm_ff / tpm > w4 else w4
        aim = pm_on + pm_ff  # self.AIM[t]
        pon0, pff0 = pmon, pmff
        if pm_ff >= ooff:
            eff = pff
            sff = inhibited(eff, eff_prev, a3, w2_kernel, w2)
        else:
            eff = zeros  # Eff[:,:,t] is left at 0
            sff = zeros
        if pm_on >= oon:
            eon = pon
            son = inhibited(eon, eon_prev, a2, w1_kernel, w1)
        else:
            eon = zeros
            son = zeros
        s = o1 * son + o2 * sff + o3 * son * sff
        ce = _filter(s, wg, _REFLECT)  # cv2.filter2D(S, -1, Wg_kernel)
        w = np.max(ce) / 4.0 + 0.01
        g = s * ce / w
        g[g * cde < tde] = 0
        k = 1.0 / (1 + math.exp(-np.sum(g) / (n * a5)))
        if aim >= 10 + 0.02 * aim_prev:
            k = 0.5
        if k - k1 <= tsfa:  # SFA
            k_cur = max(a6 * (k_pre + k - k1), 0.5)
        else:
            k_cur = max(a6 * k, 0.5)
        out.append(k_cur)
        k1, k_pre, aim_prev = k, k_cur, aim
        p_2, p_1 = p_1, p
        pon_prev, pff_prev, eon_prev, eff_prev = pon, pff, eon, eff
    return np.array(out)


#: Which preset reproduces which published file: (model, preset, parameter overrides,
#: oracle, its keyword arguments, a label).
ORACLES = [
    ("lgmd1", "published", {}, pi_lgmd, {}, "PI-LGMD models.py"),
    ("lgmd1", "lgmd-single", {}, lgmd_single, {}, "LGMDSingle.cs"),
    ("lgmd1", "plgmd", {}, plgmd, {}, "pLGMD LGMD.m"),
    ("lgmd2", "published", {}, lgmd2_open_source, {}, "lgmd2OpenSource.cs"),
    ("f_on", "published", {}, olgmd, {"pm_off_from_on_mean": False},
     "optimized_LGMD.py, PM_off bug fixed"),
    ("f_off", "published", {}, olgmd, {"pm_off_from_on_mean": False},
     "optimized_LGMD.py, PM_off bug fixed"),
    ("f_off", "published", {"pm_off_uses_on_mean": True}, olgmd, {},
     "optimized_LGMD.py as written"),
]
