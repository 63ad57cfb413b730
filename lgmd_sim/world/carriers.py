"""Camera carriers: how commands move the camera, and the shake of hand-held cameras.

- `robot`: the differential-drive robot of assets/robot.xml; a command (v, omega) sets the
  wheel servos' target speeds, and the jitter comes from the physics of driving over
  the terrain.
- `handheld`: the camera rig follows a kinematic path (a unicycle driven by the same
  commands, at `camera_height`), plus a seeded band-limited shake.
- `tripod`: the rig stands at the start; commands are ignored. A jitter above 0 gives it
  the hand-held shake (a wobbly mount), so every scenario takes the common jitter scale.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from lgmd_sim.world.params import SceneParams

#: Sinusoids per axis of the shake: enough for a noise-like, non-periodic signal.
SHAKE_COMPONENTS = 16


class Shake:
    """Seeded band-limited shake: 3 rotations (roll, pitch, yaw) and 3 translations.

    Each axis is a sum of sinusoids with log-uniform random frequencies in the band and
    amplitudes falling as 1/f (slow sway dominates, as with a hand), normalised so that
    each rotation axis has RMS `angle` (rad) and each translation axis RMS `shift` (m).
    """

    def __init__(self, rng: np.random.Generator, angle: float, shift: float,
                 band: tuple[float, float]) -> None:
        lo, hi = band
        shape = (6, SHAKE_COMPONENTS)
        self.freq = np.exp(rng.uniform(np.log(lo), np.log(hi), shape))
        self.phase = rng.uniform(0, 2 * np.pi, shape)
        amp = 1.0 / self.freq
        amp *= np.sqrt(2.0 / (amp * amp).sum(axis=1, keepdims=True))  # unit RMS per axis
        self.amp = amp * np.array([angle] * 3 + [shift] * 3)[:, None]
        self.active = angle > 0 or shift > 0

    def at(self, t: np.ndarray) -> np.ndarray:
        """Offsets (len(t), 6): roll, pitch, yaw (rad), then x, y, z (m), at times t (s)."""
        t = np.asarray(t, float)
        if not self.active:
            return np.zeros((t.size, 6))
        arg = 2 * np.pi * self.freq[:, :, None] * t[None, None, :] + self.phase[:, :, None]
        return np.einsum("ak,akt->ta", self.amp, np.sin(arg))


def pitch_roll_quat(pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Quaternions (N, 4) (w, x, y, z) of Ry(pitch) Rx(roll)."""
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    return np.stack([cp * cr, cp * sr, sp * cr, -sp * sr], axis=-1)


@njit(cache=True, nogil=True)
def yaw_then(yaw: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Quaternions Rz(yaw) q, for quaternions q (N, 4) (w, x, y, z)."""
    out = np.empty((len(yaw), 4))
    for i in range(len(yaw)):
        c, s = math.cos(yaw[i] / 2), math.sin(yaw[i] / 2)
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        out[i, 0] = c * w - s * z
        out[i, 1] = c * x - s * y
        out[i, 2] = c * y + s * x
        out[i, 3] = c * z + s * w
    return out


@njit(cache=True, nogil=True)
def _unicycle_poses(x0: float, y0: float, heading0: float, step: float, turn: float,
                    height: float, off: np.ndarray, tilts: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """Poses of a unicycle moving `step` m and turning `turn` rad per physics step, plus
    the shake `off` (n, 6) and its tilts (n, 4); and its last x, y, heading. One call
    instead of some thirty small numpy ones (the step's fixed cost)."""
    n = len(off)
    pos = np.empty((n, 3))
    yaw = np.empty(n)
    heading, dx, dy = heading0, 0.0, 0.0
    for k in range(n):
        heading = heading0 + turn * (k + 1)
        dx += step * math.cos(heading)  # the path sums from the start, then adds x0
        dy += step * math.sin(heading)
        pos[k, 0] = x0 + dx + off[k, 3]
        pos[k, 1] = y0 + dy + off[k, 4]
        pos[k, 2] = height + off[k, 5]
        yaw[k] = heading + off[k, 2]
    return pos, yaw_then(yaw, tilts), x0 + dx, y0 + dy, heading


class HeldPath:
    """The path of a hand-held or tripod rig: a unicycle at camera height, plus shake.

    Poses come one per physics step of `dt` seconds; the shake is evaluated ahead in
    chunks (an episode's sines cost less at once than a frame at a time).
    """

    CHUNK = 480  # physics steps: 2 s at 30 fps x 8 substeps

    def __init__(self, params: SceneParams, shake: Shake, dt: float) -> None:
        self.moves = params.carrier == "handheld"
        self.height = params.camera_height
        self.shake = shake
        self.dt = dt
        self.x = self.y = self.heading = 0.0
        self._step = 0  # physics steps taken
        self._chunk_start = 0
        self._offsets = np.zeros((0, 6))  # shake of the chunk: roll, pitch, yaw, x, y, z
        self._tilts = np.zeros((0, 4))  # its pitch and roll as quaternions

    @property
    def moving(self) -> bool:
        """False for a still tripod: its pose never changes after the first."""
        return self.moves or self.shake.active

    def start_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) and quaternion (4,) at time 0."""
        off = self.shake.at(np.zeros(1))
        pos = np.array([self.x, self.y, self.height]) + off[0, 3:]
        quat = yaw_then(self.heading + off[:, 2], pitch_roll_quat(off[:, 1], off[:, 0]))
        return pos, quat[0]

    def advance(self, v: float, omega: float, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Poses (positions (n, 3), quaternions (n, 4)) for the next n physics steps."""
        k = self._step - self._chunk_start
        if k + n > len(self._offsets):  # evaluate the shake ahead
            self._chunk_start, k = self._step, 0
            times = (self._step + 1 + np.arange(max(n, self.CHUNK))) * self.dt
            self._offsets = self.shake.at(times)
            self._tilts = pitch_roll_quat(self._offsets[:, 1], self._offsets[:, 0])
        self._step += n
        step, turn = (v * self.dt, omega * self.dt) if self.moves else (0.0, 0.0)
        pos, quat, self.x, self.y, self.heading = _unicycle_poses(
            self.x, self.y, self.heading, step, turn, self.height, self._offsets[k:k + n],
            self._tilts[k:k + n])
        return pos, quat


def wheel_speeds(v: float, omega: float, radius: float, track: float) -> tuple[float, float]:
    """Left and right wheel angular speeds (rad/s) for body velocities (v, omega)."""
    return (v - omega * track / 2) / radius, (v + omega * track / 2) / radius
