"""Ego-motion compensation front ends: the camera's rotation between frames, removed.

A rotating camera moves every pixel, and a frame-difference model (P = L(t) - L(t-1))
sees the whole frame move: that is what saturates the LGMDs under jitter. A pure rotation
R of the camera between frames moves pixels by the homography H = K R K^-1 (K the
camera's intrinsics, from its vertical field of view and the frame size), whatever the
depth. The front end gives the model H each frame; the model warps every stored map
(previous frame, inhibition and feedback histories) by it before taking the frame
(`lgmd_sim.models.base.LGMDModel.step`, `lgmd_sim.models.warp`), so that P compares
each pixel with the same direction in the world.

Where R comes from (the model parameter ``stabilize``):

- "pose" / "imu": given to ``step(frame, rotation=r)`` each frame, a rotation vector (rad)
  in the camera frame (x right, y up, z backwards: MuJoCo's): the rotation of the camera
  from the previous frame to this one, as the jitter environments report it in
  ``info["pose_rotation"]`` (exact, from the poses) and ``info["imu_rotation"]`` (the
  gyro integrated over the physics steps of the frame, with optional noise and bias).
- "image": fitted from the frames alone (`ImageRotation`): corners tracked from the
  previous frame to this one (OpenCV's Shi-Tomasi corners and pyramidal Lucas-Kanade)
  become pairs of rays K^-1 x; a small RANSAC over 2-point minimal samples fits a pure
  3-D rotation, refined by least squares (Kabsch) on its inliers.

``gain=True`` also fits the brightness gain between frames (`brightness_gain`: a smooth
field of the median ratios of this frame to the warped previous one, block by block),
and the previous frame is scaled by it: auto-exposure, a passing shade or flicker then
do not read as motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numba import njit

from lgmd_sim.core.params import CheckedParams, in_range, int_in_range, one_of, param
from lgmd_sim.models.warp import Motion

__all__ = ["FrontEnd", "ImageRotation", "ImageRotationParams", "brightness_gain",
           "gain_field", "gain_grid", "ground_motion", "intrinsics", "rotation_homography",
           "rotation_matrix", "rotation_vector"]

#: MuJoCo's camera frame (x right, y up, z backwards) to the image's (x right, y down,
#: z forwards, the frame K works in): flip y and z.
_FLIP = np.diag([1.0, -1.0, -1.0])


def intrinsics(fovy_deg: float, height: int, width: int) -> np.ndarray:
    """K (3x3) of a pinhole camera: focal length from the vertical field of view, square
    pixels, principal point at the frame's centre (pixel centres at integers)."""
    f = 0.5 * height / math.tan(math.radians(fovy_deg) / 2.0)
    return np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0],
                     [0.0, 0.0, 1.0]])


def rotation_matrix(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) (Rodrigues)."""
    r = np.asarray(rotvec, np.float64)
    theta = np.linalg.norm(r, axis=-1)[..., None, None]
    k = np.zeros((*r.shape[:-1], 3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -r[..., 2], r[..., 1], -r[..., 0]
    k = k - np.swapaxes(k, -1, -2)  # [r]x
    small = theta < 1e-8
    t = np.where(small, 1.0, theta)
    a = np.where(small, 1.0, np.sin(t) / t)
    b = np.where(small, 0.5, (1.0 - np.cos(t)) / (t * t))
    return np.eye(3) + a * k + b * (k @ k)


def rotation_vector(rot: np.ndarray) -> np.ndarray:
    """The rotation vector (3,) of a rotation matrix (3, 3)."""
    vec, _ = cv2.Rodrigues(np.asarray(rot, np.float64))
    return vec[:, 0]


def rotation_homography(rotvec: np.ndarray, k: np.ndarray) -> np.ndarray:
    """H = K R K^-1 (previous -> current pixels) for camera rotations (..., 3) given as
    rotation vectors in MuJoCo's camera frame (the camera's turn from the previous frame
    to this one, in the previous camera's frame)."""
    turn = rotation_matrix(rotvec)  # columns: the new camera's axes in the old one's
    points = _FLIP @ np.swapaxes(turn, -1, -2) @ _FLIP  # old camera coordinates -> new
    return k @ points @ np.linalg.inv(k)


def ground_motion(rotvec: np.ndarray, displacement: np.ndarray, up: np.ndarray,
                  height: float, k: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The motion of a camera that turns and moves over a ground plane: (rotation
    homography, horizon line, ground homography), as `Motion` takes them.

    Points at infinity move by the rotation alone (H = K R K^-1); points on the ground by
    the plane-induced homography H = K R (I - c n^T / d) K^-1 (c the camera's
    displacement, n the ground's normal towards it and d its height, in the previous
    camera's frame). The horizon separates them in the current frame.

    Args:
        rotvec: the camera's turn since the previous frame (as `rotation_homography`).
        displacement: the camera's move since the previous frame (m), in the previous
            camera's frame (MuJoCo's camera axes: x right, y up, z backwards).
        up: the ground's upward normal in the previous camera's frame (MuJoCo's axes).
        height: the camera's height above the ground (m).
        k: the camera's intrinsics (`intrinsics`).
    """
    turn = rotation_matrix(rotvec)
    points = _FLIP @ turn.T @ _FLIP  # previous camera coordinates -> current
    c = _FLIP @ np.asarray(displacement, np.float64)
    down = -(_FLIP @ np.asarray(up, np.float64))
    down /= np.linalg.norm(down)
    k_inv = np.linalg.inv(k)
    rotation = k @ points @ k_inv
    ground = k @ points @ (np.eye(3) - np.outer(c, down) / height) @ k_inv
    horizon = (points @ down) @ k_inv  # rays of the current frame that point down
    return rotation, horizon, ground


# --- image-only rotation --------------------------------------------------------------------


@dataclass(frozen=True)
class ImageRotationParams(CheckedParams):
    """How `ImageRotation` fits the camera's rotation from two frames."""

    scale: int = param(2, "ours: measured (python -m scripts.speed stabilize; "
                          "docs/experiments/models-log.md)",
                       check=one_of(1, 2, 4),
                       doc="frames are tracked at 1/scale of their size (2: halved)")
    max_corners: int = param(100, "ours: measured (as scale)", check=int_in_range(8, 2000),
                             doc="most corners tracked per frame (Shi-Tomasi)")
    quality: float = param(0.01, "OpenCV's usual goodFeaturesToTrack qualityLevel",
                           check=in_range(1e-4, 1.0),
                           doc="corners weaker than this share of the strongest are dropped")
    min_distance: float = param(8.0, "ours: spreads corners over the frame",
                                check=in_range(1.0, 100.0),
                                doc="least distance between corners (tracked pixels)")
    window: int = param(11, "ours: measured (as scale)", check=int_in_range(5, 51),
                        doc="Lucas-Kanade window side (tracked pixels)")
    levels: int = param(2, "ours: follows shifts of up to about 2^levels x window / 2 "
                        "tracked pixels, 44 full-size pixels (8 degrees at 270x480)",
                        check=int_in_range(0, 6), doc="pyramid levels above the frame")
    hypotheses: int = param(64, "ours: with half the tracks inliers, a clean pair is "
                            "drawn with probability 1 - 0.75^64 > 0.999",
                            check=int_in_range(1, 4096), doc="RANSAC 2-point samples")
    inlier_px: float = param(1.0, "ours: about the tracks' error at the tracked size",
                             check=in_range(0.05, 50.0),
                             doc="a track is an inlier within this many pixels (full size)")
    min_inliers: int = param(8, "ours", check=int_in_range(2, 1000),
                             doc="fewer inliers: no rotation is trusted (identity)")


class ImageRotation:
    """Fits the camera's rotation between consecutive frames of one stream from the frames.

    Each frame is shrunk (``scale``) and kept with its corners, which are tracked into the
    next frame; a rotation is fitted to the tracks. Deterministic (the RANSAC samples come
    from a fixed seed), so a stream gives the same rotations alone or in a batch.

    Args:
        fovy: vertical field of view (degrees).
        **params: overrides of `ImageRotationParams`.
    """

    def __init__(self, fovy: float, **params: Any) -> None:
        self.params = ImageRotationParams(**params)
        self.fovy = float(fovy)
        self._prev: tuple[np.ndarray, np.ndarray | None] | None = None

    def reset(self) -> None:
        """Forget the previous frame: the next one starts a new stream."""
        self._prev = None

    def update(self, frame: np.ndarray) -> tuple[np.ndarray, int]:
        """Take the next uint8 grey frame; return the rotation R (3x3, image camera frame:
        previous -> current camera coordinates, x_t ~ K R K^-1 x_{t-1}) since the previous
        frame, and the number of tracks that agree with it (0: identity, none trusted or
        no previous frame)."""
        p = self.params
        small = frame
        for _ in range(p.scale.bit_length() - 1):
            small = cv2.pyrDown(small)
        prev, self._prev = self._prev, (small, cv2.goodFeaturesToTrack(
            small, p.max_corners, p.quality, p.min_distance / p.scale))
        if prev is None or prev[1] is None or prev[0].shape != small.shape:
            return np.eye(3), 0
        moved, status, _err = cv2.calcOpticalFlowPyrLK(
            prev[0], small, prev[1], None, winSize=(p.window, p.window), maxLevel=p.levels)
        ok = status[:, 0] == 1
        # pyrDown: small pixel i sits on full pixel 2i
        return self.fit(prev[1][ok, 0] * p.scale, moved[ok, 0] * p.scale, frame.shape)

    def fit(self, a: np.ndarray, b: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, int]:
        """The rotation taking points `a` (M, 2) of the previous frame to `b` of this one
        (full-size pixels of a frame of this shape), and its number of inliers."""
        p = self.params
        if len(a) < max(p.min_inliers, 2):
            return np.eye(3), 0
        k = intrinsics(self.fovy, *shape)
        ra = _unit((np.asarray(a, np.float64) - k[:2, 2]) / k[0, 0])
        rb = _unit((np.asarray(b, np.float64) - k[:2, 2]) / k[0, 0])
        tol = p.inlier_px / k[0, 0]  # chord between unit rays, about the angle
        rng = np.random.default_rng(0)
        i = rng.integers(len(ra), size=p.hypotheses)
        j = (i + 1 + rng.integers(len(ra) - 1, size=p.hypotheses)) % len(ra)
        inliers = _ransac(ra, rb, i, j, tol)
        for _ in range(2):  # least squares on the inliers, then on its own inliers
            if inliers.sum() < p.min_inliers:
                return np.eye(3), 0
            rot = _kabsch(ra[inliers], rb[inliers])
            inliers = np.linalg.norm(ra @ rot.T - rb, axis=1) < tol
        return rot, int(inliers.sum())


def _unit(xy: np.ndarray) -> np.ndarray:
    """Unit rays (M, 3) through normalised image points (M, 2)."""
    rays = np.column_stack([xy, np.ones(len(xy))])
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


@njit(cache=True, nogil=True)
def _ransac(ra, rb, first, second, tol):
    """The inliers (within chord `tol`) of the best rotation among those fixed by the
    pairs of rays (first[h], second[h]): each maps the triad u, u x v, u x (u x v) of
    the previous rays onto that of the current ones. (Scalar loops: numba's matrix
    products would need SciPy's BLAS.)"""
    best = np.zeros(len(ra), np.bool_)
    best_count = -1
    ok = np.zeros(len(ra), np.bool_)
    ta = np.empty((3, 3))
    tb = np.empty((3, 3))
    rot = np.empty((3, 3))
    tol2 = tol * tol
    for h in range(len(first)):
        if not (_triad(ra[first[h]], ra[second[h]], ta)
                and _triad(rb[first[h]], rb[second[h]], tb)):
            continue
        for r in range(3):  # rot = tb ta^T
            for c in range(3):
                rot[r, c] = tb[r, 0] * ta[c, 0] + tb[r, 1] * ta[c, 1] + tb[r, 2] * ta[c, 2]
        count = 0
        for m in range(len(ra)):
            d2 = 0.0
            for r in range(3):
                d = rot[r, 0] * ra[m, 0] + rot[r, 1] * ra[m, 1] + rot[r, 2] * ra[m, 2] - rb[m, r]
                d2 += d * d
            ok[m] = d2 < tol2
            count += ok[m]
        if count > best_count:
            best[:] = ok
            best_count = count
    return best


@njit(cache=True, nogil=True)
def _triad(u, v, out):
    """Columns u, w = u x v / |u x v|, u x w into `out`; False for (nearly) parallel rays."""
    w0 = u[1] * v[2] - u[2] * v[1]
    w1 = u[2] * v[0] - u[0] * v[2]
    w2 = u[0] * v[1] - u[1] * v[0]
    norm = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if norm < 1e-9:
        return False
    w0, w1, w2 = w0 / norm, w1 / norm, w2 / norm
    out[0, 0], out[1, 0], out[2, 0] = u[0], u[1], u[2]
    out[0, 1], out[1, 1], out[2, 1] = w0, w1, w2
    out[0, 2] = u[1] * w2 - u[2] * w1
    out[1, 2] = u[2] * w0 - u[0] * w2
    out[2, 2] = u[0] * w1 - u[1] * w0
    return True


def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation R minimising sum |R a_i - b_i|^2 (Kabsch)."""
    u, _s, vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    return u @ np.diag([1.0, 1.0, d]) @ vt


# --- brightness -------------------------------------------------------------------------------

#: The gain field's grid (rows, columns): a gain per block of about 30 x 30 pixels at
#: 270 x 480, smooth in between. Lighting changes are not global: a passing shade or a
#: flickering sun changes the lit ground, not the sky, and one gain for the whole frame
#: then turned the sky into P (measured: docs/experiments/models-log.md, "Brightness").
GAIN_GRID = (9, 16)
#: Each block is judged on this many x this many pixels of the frames shrunk to the grid.
_GAIN_CELL = 8
#: Pixels this dark or this bright in either frame say little about a gain (noise,
#: clipping) and are left out; a block needs a quarter of its pixels to have a gain of
#: its own, else it takes the frame's.
_GAIN_RANGE = (8.0, 247.0)
_GAIN_MIN_SHARE = 0.25


def brightness_gain(prev: np.ndarray, cur: np.ndarray, homography: np.ndarray | None
                    ) -> np.ndarray:
    """The brightness of `cur` over the previous frame `prev` warped into it (uint8 grey
    frames; homography previous -> current pixels, None for none), as a smooth gain field
    (H, W) float32: per block of `GAIN_GRID` the median ratio of their pixels (robust to
    what moves on its own within the block), interpolated between the blocks' centres."""
    return gain_field(gain_grid(prev, cur, homography), cur.shape)


def gain_field(grid: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The gain field (H, W) float32 of a `gain_grid`, interpolated between the blocks'
    centres: what a calibration stores per frame (the grid) gives the model's field."""
    return cv2.resize(grid, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)


def gain_grid(prev: np.ndarray, cur: np.ndarray, homography: np.ndarray | None
              ) -> np.ndarray:
    """`brightness_gain`'s gain per block of `GAIN_GRID`, (rows, cols) float32 (ones where
    no pixel tells a gain)."""
    rows, cols = GAIN_GRID
    h, w = rows * _GAIN_CELL, cols * _GAIN_CELL
    small = [cv2.resize(f, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32)
             for f in (prev, cur)]
    before, after = small
    covered = np.ones((h, w), np.float32)
    if homography is not None:  # into the shrunk frames' pixel coordinates
        sx, sy = w / cur.shape[1], h / cur.shape[0]
        scale = np.array([[sx, 0, 0.5 * sx - 0.5], [0, sy, 0.5 * sy - 0.5], [0, 0, 1]])
        hs = scale @ homography @ np.linalg.inv(scale)
        before = cv2.warpPerspective(before, hs, (w, h), flags=cv2.INTER_LINEAR)
        covered = cv2.warpPerspective(covered, hs, (w, h), flags=cv2.INTER_NEAREST)
    lo, hi = _GAIN_RANGE
    ok = (covered > 0) & (before > lo) & (before < hi) & (after > lo) & (after < hi)
    if not ok.any():
        return np.ones(GAIN_GRID, np.float32)
    ratio = np.where(ok, after / np.where(ok, before, 1.0), np.nan)
    blocks = ratio.reshape(rows, _GAIN_CELL, cols, _GAIN_CELL).transpose(0, 2, 1, 3)
    blocks = blocks.reshape(rows, cols, -1)
    enough = np.isfinite(blocks).mean(axis=-1) >= _GAIN_MIN_SHARE
    gains = np.full((rows, cols), np.median(ratio[ok]), np.float32)
    gains[enough] = _nan_median(blocks[enough])
    return gains


def _nan_median(rows: np.ndarray) -> np.ndarray:
    """np.nanmedian(rows, axis=-1), the same values, for rows with a finite value each:
    one sort with NaN last (nanmedian goes through masked arrays, 10x slower here)."""
    ordered = np.sort(rows, axis=-1)  # NaN sorts last
    k = np.isfinite(ordered).sum(axis=-1)
    at = np.arange(len(ordered))
    return (ordered[at, (k - 1) // 2] + ordered[at, k // 2]) / ordered.dtype.type(2)


# --- the front end of a model -------------------------------------------------------------------


class FrontEnd:
    """Per frame and stream, the `Motion` (homography and gain) a model is warped by.

    Built by `lgmd_sim.models.base.LGMDModel` from its parameters ``stabilize``,
    ``fovy`` and ``gain``; it keeps each stream's previous grey frame (for the image fit
    and the gain) and forgets it when the stream is reset.
    """

    def __init__(self, params: Any, n_streams: int) -> None:
        self.source: str = params.stabilize
        self.fovy: float = params.fovy
        self.gain: bool = params.gain
        self.n = n_streams
        self.trackers = ([ImageRotation(self.fovy) for _ in range(n_streams)]
                         if self.source == "image" else [])
        self._prev: list[np.ndarray | None] = [None] * n_streams
        #: Per stream, the camera's turn the last image fit found (a rotation vector, rad,
        #: as ``rotation`` takes them) and the tracks that agreed with it (image source).
        self.rotations = np.zeros((n_streams, 3))
        self.inliers = np.zeros(n_streams, np.int64)
        #: Per stream, the last frame's `gain_grid` (ones on a stream's first frame).
        self.gain_grids = np.ones((n_streams, *GAIN_GRID), np.float32)

    def reset(self, streams: np.ndarray | None) -> None:
        """Forget the previous frame of these streams (all of them for None)."""
        for i in range(self.n) if streams is None else streams:
            self._prev[i] = None
            if self.trackers:
                self.trackers[i].reset()

    def motion(self, grey: np.ndarray, rotation: np.ndarray | None) -> Motion:
        """The motion of each stream from its previous frame to `grey` (N, H, W)."""
        n, height, width = grey.shape
        frames = grey if grey.dtype == np.uint8 else np.clip(grey + 0.5, 0, 255).astype(np.uint8)
        k = intrinsics(self.fovy, height, width)
        hs = None
        if self.source in ("pose", "imu"):
            hs = rotation_homography(self._rotations(rotation, n), k)
        elif self.source == "image":
            hs = np.empty((n, 3, 3))
            for i in range(n):
                rot, self.inliers[i] = self.trackers[i].update(frames[i])
                self.rotations[i] = rotation_vector(_FLIP @ rot.T @ _FLIP)
                hs[i] = k @ rot @ np.linalg.inv(k)
        gains = None
        if self.gain:
            gains = np.ones((n, height, width), np.float32)
            self.gain_grids[:] = 1.0
            for i in range(n):
                if self._prev[i] is not None and self._prev[i].shape == frames[i].shape:
                    self.gain_grids[i] = gain_grid(self._prev[i], frames[i],
                                                   None if hs is None else hs[i])
                    gains[i] = gain_field(self.gain_grids[i], frames[i].shape)
                self._prev[i] = frames[i].copy()
        return Motion(hs, gains)

    def _rotations(self, rotation: np.ndarray | None, n: int) -> np.ndarray:
        key = "pose_rotation" if self.source == "pose" else "imu_rotation"
        if rotation is None:
            raise ValueError(f"stabilize={self.source!r} needs the camera's rotation each "
                             f"frame: step(frame, rotation=info[{key!r}])")
        r = np.asarray(rotation, np.float64)
        want = (3,) if self.n == 1 and r.ndim == 1 else (n, 3)
        if r.shape != want or not np.isfinite(r).all():
            raise ValueError(f"rotation must be a finite rotation vector per stream, shape "
                             f"{want}, got {r.shape}")
        return r.reshape(n, 3)
