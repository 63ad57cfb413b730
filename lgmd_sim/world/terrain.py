"""Rough ground: seeded fractal-noise heightfields and the textures that make motion visible.

The heightfield is fractional-Brownian-like noise made by filtering white noise in the
Fourier domain: its power falls as (k^2 + k0^2)^-(H+1) with k0 = 1 / scale, so bumps up to
about `scale` metres across carry the energy and finer ones fade with the Hurst exponent H.
It is scaled to the requested RMS height, raised so that its lowest point is at zero and
tapered to zero at the border, where it meets the flat ground plane around it.
"""

from __future__ import annotations

import math

import numpy as np

#: Hurst exponent of the terrain noise: 0.8 gives natural-looking rough ground.
HURST = 0.8
#: Width (m) of the border over which the rough patch blends into the flat plane.
TAPER = 0.6
#: The patch is drawn in square tiles of this many cells a side, each also in a coarse
#: version keeping every COARSE_STEP-th point (see lgmd_sim.world.core's level of detail).
TILE_CELLS, COARSE_STEP = 20, 4


def tile_grid(arena: tuple[float, float], cell: float) -> tuple[int, int]:
    """Tiles (along y, along x) of a rough patch: `arena` (length, width) rounded up."""
    tile = TILE_CELLS * cell
    return (max(1, math.ceil(arena[1] / tile - 1e-9)),
            max(1, math.ceil(arena[0] / tile - 1e-9)))


def fractal_heights(
    rng: np.random.Generator,
    nrow: int,
    ncol: int,
    cell: float,
    roughness: float,
    scale: float,
) -> np.ndarray:
    """Heights (nrow, ncol) in metres, >= 0, zero on the border.

    Args:
        rng: the random source (seeded by the caller).
        nrow, ncol: grid points along y and x.
        cell: grid spacing in metres.
        roughness: RMS height of the bumps in metres before the border taper; 0 is flat.
        scale: spatial scale in metres: the size of the largest bumps.
    """
    if roughness == 0:
        return np.zeros((nrow, ncol))
    ky = np.fft.fftfreq(nrow, d=cell)[:, None]
    kx = np.fft.rfftfreq(ncol, d=cell)[None, :]
    amplitude = (kx * kx + ky * ky + (1.0 / scale) ** 2) ** (-(HURST + 1) / 2)
    amplitude[0, 0] = 0.0  # no mean offset
    noise = rng.standard_normal((nrow, ncol))
    h = np.fft.irfft2(np.fft.rfft2(noise) * amplitude, s=(nrow, ncol))
    h *= roughness / max(float(h.std()), 1e-12)
    h -= h.min()
    return h * _border_window(nrow, ncol, cell)


def _border_window(nrow: int, ncol: int, cell: float) -> np.ndarray:
    def ramp(n: int) -> np.ndarray:
        edge = np.minimum(np.arange(n), np.arange(n)[::-1]) * cell / TAPER
        t = np.clip(edge, 0.0, 1.0)
        return t * t * (3 - 2 * t)  # smoothstep: no kink where the patch meets the plane

    return ramp(nrow)[:, None] * ramp(ncol)[None, :]


def height_at(heights: np.ndarray, cell: float, origin: tuple[float, float],
              x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
    """Bilinear height at world points (x, y); 0 outside the patch.

    ``origin`` is the world (x, y) of grid point [0, 0]; rows run along +y, columns along +x
    (MuJoCo's heightfield layout).
    """
    nrow, ncol = heights.shape
    gx = (np.asarray(x, float) - origin[0]) / cell
    gy = (np.asarray(y, float) - origin[1]) / cell
    inside = (gx >= 0) & (gx <= ncol - 1) & (gy >= 0) & (gy <= nrow - 1)
    gx, gy = np.clip(gx, 0, ncol - 1.000001), np.clip(gy, 0, nrow - 1.000001)
    c0, r0 = gx.astype(int), gy.astype(int)
    fx, fy = gx - c0, gy - r0
    h = (heights[r0, c0] * (1 - fx) * (1 - fy) + heights[r0, c0 + 1] * fx * (1 - fy)
         + heights[r0 + 1, c0] * (1 - fx) * fy + heights[r0 + 1, c0 + 1] * fx * fy)
    return np.where(inside, h, 0.0)


def ground_texture(rng: np.random.Generator, size: int, palette: np.ndarray) -> np.ndarray:
    """A tileable (size, size, 3) uint8 ground texture: blotches of a 3-colour palette.

    Multi-octave noise with most of its energy in blotches a few texels to a quarter of the
    tile across, so that texture flow is visible without the fine-grained detail that would
    make any sub-pixel motion collapse the SSIM of consecutive frames.
    """
    k = np.fft.fftfreq(size)
    kk = np.sqrt(k[:, None] ** 2 + k[None, :] ** 2)
    fields = []
    for _ in range(2):
        spectrum = np.fft.fft2(rng.standard_normal((size, size)))
        spectrum *= np.where(kk > 0, (kk + 4.0 / size) ** -1.6, 0.0) * np.exp(-(kk / 0.12) ** 2)
        f = np.fft.ifft2(spectrum).real
        fields.append((f - f.mean()) / f.std())
    # Palette weights from two smooth fields: colour 0 base, 1 and 2 in patches.
    w1 = 1 / (1 + np.exp(-2.5 * fields[0]))
    w2 = 1 / (1 + np.exp(-2.5 * fields[1]))
    pal = np.asarray(palette, float)
    rgb = (pal[0] * ((1 - w1) * (1 - w2))[..., None] + pal[1] * (w1 * (1 - w2))[..., None]
           + pal[2] * w2[..., None])
    return np.clip(rgb, 0, 255).astype(np.uint8)
