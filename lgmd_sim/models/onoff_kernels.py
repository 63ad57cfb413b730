"""The numba kernels of the ON/OFF models: LGMD2 (`lgmd_sim.models.lgmd2`) and, through
it, the F(ON)/F(OFF) LGMDs (`lgmd_sim.models.ffi`). `rectified_sums` gives the whole-field
sums of [P]+ and [-P]+ that PM needs before the frame; `onoff_frames` runs one frame per
stream up to sum G, row by row (P, ON, OFF, the delayed copies, S, G), as
`lgmd_sim.models.kernels` describes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from lgmd_sim.models.baseline import diff_row, finish_s_row, g_row, g_sum, persist_row
from lgmd_sim.models.kernels import JIT, fill_borders_as, row_index

__all__ = ["onoff_frames", "rectified_sums"]


@njit(**JIT)
def _p_row(frames, prev, p_hist, n, y, c1, c2, persist, out):
    """Row y of stream n's P into ``out`` (P(t-1), P(t-2) from ``p_hist`` where persisting)."""
    if persist:
        persist_row(frames[n, y], prev[n, y], p_hist[n, 0, y], p_hist[n, 1, y], c1, c2, out)
    else:
        diff_row(frames[n, y], prev[n, y], out)


@njit(**JIT)
def rectified_sums(frames: np.ndarray, prev: np.ndarray, p_hist: np.ndarray,
                   persist_w: np.ndarray, persist_on: np.ndarray, line: np.ndarray,
                   out: np.ndarray) -> None:
    """out[n] = (sum [P]+, sum [-P]+) of stream n's P (nothing is written back)."""
    n_streams, height, width = frames.shape
    zero = np.float32(0.0)
    for n in range(n_streams):
        pos = 0.0
        neg = 0.0
        for y in range(height):
            _p_row(frames, prev, p_hist, n, y, persist_w[n, 0], persist_w[n, 1],
                   persist_on[n], line)
            acc_pos = zero
            acc_neg = zero
            for x in range(width):
                acc_pos += max(line[x], zero)
                acc_neg += max(-line[x], zero)
            pos += acc_pos
            neg += acc_neg
        out[n, 0] = pos
        out[n, 1] = neg


@njit(**JIT)
def _inhibition(c1, n0, n1, n2, d0, d2, wc, wn, wd, x):
    """I at column x: the 3x3 kernel over the centre (c), near (n) and diagonal (d)
    delayed copies, given as padded rows (index 0, 1, 2: rows y-1, y, y+1)."""
    return wc * c1[x + 1] + wn * (n0[x + 1] + n2[x + 1] + n1[x] + n1[x + 2]) + wd * (
        d0[x] + d0[x + 2] + d2[x] + d2[x + 2])


#: Decaying state (ON, OFF, the low-passes) below this many grey levels is set to 0: left
#: alone it would sink into subnormal floats, which x86 processes about 100 times slower,
#: and a first-order decay sticks at the smallest subnormal for good. Far below the input's
#: resolution of one grey level; the float64 reference does not need it.
_FLUSH = np.float32(1e-6)


@njit(**JIT)
def _low_pass_row(lp_row, source, alpha, gain, border):
    """One padded row of a first-order low-pass: lp += alpha (gain source - lp)."""
    width = source.shape[0]
    zero = np.float32(0.0)
    for x in range(width):
        v = lp_row[x + 1] + alpha * (gain * source[x] - lp_row[x + 1])
        lp_row[x + 1] = v if v >= _FLUSH else zero
    fill_borders_as(lp_row, 1, width, border)


@njit(**JIT)
def _channel_row(p, channel, carry, sign):
    """One row of ON = [P]+ + carry ON(t-1) (sign 1) or OFF = [-P]+ + carry OFF(t-1) (-1).

    A loop of its own: fused with P and the previous frame's update, it measured slower.
    """
    zero = np.float32(0.0)
    for x in range(p.shape[0]):
        v = max(sign * p[x], zero) + carry * channel[x]
        channel[x] = v if v >= _FLUSH else zero


@njit(**JIT)
def _mix_row(out, current, previous, a, b, border):
    """One padded row of a two-frame delayed copy: out = a X(t) + b X(t-1)."""
    width = current.shape[0]
    for x in range(width):
        out[x + 1] = a * current[x] + b * previous[x]
    fill_borders_as(out, 1, width, border)


@njit(**JIT)
def onoff_frames(frames: np.ndarray, prev: np.ndarray, on: np.ndarray, off: np.ndarray,
                 lp: np.ndarray, mix: np.ndarray, p_hist: np.ndarray, persist_w: np.ndarray,
                 persist_on: np.ndarray, w_on: np.ndarray, w_off: np.ndarray,
                 gates: np.ndarray, hist_now: np.ndarray, hist_prev: np.ndarray,
                 carry: np.float32, weights: np.ndarray, alphas: np.ndarray, two_frame: bool,
                 onoff: np.float32, border: int, interior: bool, delta_c: float, c_w: float,
                 c_de: float, t_de: float, s_ring: np.ndarray, lines: np.ndarray,
                 vsum: np.ndarray, q: np.ndarray, ce_cols: np.ndarray, want: bool,
                 l_p: np.ndarray, l_on: np.ndarray, l_off: np.ndarray, l_s: np.ndarray,
                 l_g: np.ndarray, g_total: np.ndarray) -> None:
    """One frame per stream of the ON/OFF models, up to sum G.

    Row pipeline: row y's P, ON and OFF (and, "two-frame", its delayed copies, into the
    3-row ring ``mix``); then S of row y-1, whose inhibition reads the delayed copies of
    rows y-2..y; then G of row y-2. "Low-pass": the low-passes ``lp`` hold the previous
    frames (delay of at least one frame), and row y-2 is advanced to ON(t) / OFF(t) once
    S of row y-1 has read it.
    """
    n_streams, height, width = frames.shape
    zero = np.float32(0.0)
    one = np.float32(1.0)
    wc_on, wn_on, wd_on = weights[0], weights[1], weights[2]
    wc_off, wn_off, wd_off = weights[3], weights[4], weights[5]
    pl, old_on, old_off = lines[0], lines[1], lines[2]
    for n in range(n_streams):
        won = w_on[n]
        woff = w_off[n]
        g_on = gates[n, 0]
        g_off = gates[n, 1]
        persist = persist_on[n]
        c1 = persist_w[n, 0]
        c2 = persist_w[n, 1]
        delayed = mix if two_frame else lp[n]
        n_rows = delayed.shape[1] - 1  # image rows it holds; then a zero row
        ce_cols[:] = zero
        for y in range(height + 2):
            if y < height:  # P, ON, OFF of row y
                fr = frames[n, y]
                pr = prev[n, y]
                onr = on[n, y]
                offr = off[n, y]
                _p_row(frames, prev, p_hist, n, y, c1, c2, persist, pl)
                if persist:  # P(t-2) <- P(t-1) <- P(t)
                    p_hist[n, 1, y] = p_hist[n, 0, y]
                    p_hist[n, 0, y] = pl
                for x in range(width):
                    pr[x] = fr[x]
                if two_frame:  # the last frame's values, for the mix
                    old_on[:] = onr
                    old_off[:] = offr
                _channel_row(pl, onr, carry, one)  # ON
                _channel_row(pl, offr, carry, -one)  # OFF
                if two_frame:  # a E(t) + (1 - a) E(t-1), E = the channel while its gate passes
                    slot = y % 3
                    for k in range(3):
                        a_on = alphas[k]
                        a_off = alphas[k + 3]
                        _mix_row(mix[k, slot], onr, old_on, a_on * hist_now[n, 0],
                                 (one - a_on) * hist_prev[n, 0], border)
                        _mix_row(mix[k + 3, slot], offr, old_off, a_off * hist_now[n, 1],
                                 (one - a_off) * hist_prev[n, 1], border)
                if want:
                    l_p[n, y] = pl
                    l_on[n, y] = onr
                    l_off[n, y] = offr
            if 1 <= y <= height:  # S of row r
                r = y - 1
                above = row_index(r - 1, n_rows, height, border)
                here = r % n_rows
                below = row_index(r + 1, n_rows, height, border)
                c_on = delayed[0, here]
                n0_on, n1_on, n2_on = delayed[1, above], delayed[1, here], delayed[1, below]
                d0_on, d2_on = delayed[2, above], delayed[2, below]
                c_of = delayed[3, here]
                n0_of, n1_of, n2_of = delayed[4, above], delayed[4, here], delayed[4, below]
                d0_of, d2_of = delayed[5, above], delayed[5, below]
                onr = on[n, r]
                offr = off[n, r]
                sr = s_ring[r % 3]
                for x in range(width):
                    i_on = _inhibition(c_on, n0_on, n1_on, n2_on, d0_on, d2_on, wc_on, wn_on,
                                       wd_on, x)
                    i_off = _inhibition(c_of, n0_of, n1_of, n2_of, d0_of, d2_of, wc_off, wn_off,
                                        wd_off, x)
                    s_on = max(onr[x] - won * i_on, zero) * g_on  # S_on = [ON - W_on I_on]+
                    s_off = max(offr[x] - woff * i_off, zero) * g_off  # [OFF - W_off I_off]+
                    sr[x + 1] = s_on + s_off + onoff * (s_on * s_off)
                finish_s_row(sr, r, height, width, interior, border)
                if want:
                    l_s[n, r] = sr[1:width + 1]
                if not two_frame and r >= 1:
                    _advance_low_passes(lp, on, off, alphas, hist_now, n, r - 1, border)
            if y >= 2:
                g_row(s_ring[row_index(y - 3, 3, height, border)], s_ring[(y - 2) % 3],
                      s_ring[row_index(y - 1, 3, height, border)], vsum, q[y - 2], ce_cols)
        if not two_frame:
            _advance_low_passes(lp, on, off, alphas, hist_now, n, height - 1, border)
        g_total[n] = g_sum(q, ce_cols, delta_c, c_w, c_de, t_de, want,
                           l_g[n] if want else q)


@njit(**JIT)
def _advance_low_passes(lp, on, off, alphas, hist_now, n, row, border):
    """Row ``row`` of stream n's six low-passes takes in ON(t) / OFF(t) (their E)."""
    for k in range(3):
        _low_pass_row(lp[n, k, row], on[n, row], alphas[k], hist_now[n, 0], border)
        _low_pass_row(lp[n, k + 3, row], off[n, row], alphas[k + 3], hist_now[n, 1], border)
