"""Offscreen rendering of a camera and the streaming SSIM of consecutive frames.

`OffscreenRenderer` renders a model's cameras straight into reusable buffers, so that a
frame costs the GL work and one flip, nothing else. All renderers of a thread share one
OpenGL context (EGL or OSMesa, see `lgmd_sim.world.gl`), each with its own MuJoCo render
context: a new GL context costs a quarter of a second of shader compilation on Mesa's
software renderer, a MuJoCo context on an existing one a few milliseconds. Worker
processes (vector envs) each have their own. `SSIMStream` gives each new frame's SSIM
with the previous one at the price of three Gaussian blurs (the previous frame's two are
kept), with the definition of `lgmd_sim.metrics.ssim`.

Fork safety: a process forked after EGL was initialised hangs when it creates a context
(Mesa's driver state does not survive fork). So before any fork (``gym.make_vec(...,
vectorization_mode="async")`` forks by default on Linux) every renderer of this module is
closed, the shared contexts freed and the EGL display terminated; renderers are
re-created on their next frame, in the parent and in each child. GL contexts made
outside lgmd-sim in the same process do not survive a fork either.
"""

from __future__ import annotations

import os
import sys
import threading
import weakref

import cv2
import numba
import numpy as np

from lgmd_sim.world.gl import BACKEND, mujoco

# SSIM as lgmd_sim.metrics.ssim (Wang et al. 2004): 11 x 11 Gaussian window, sigma 1.5,
# K1 = 0.01, K2 = 0.03 on 0..255 frames, averaged where the whole window fits.
SSIM_WINDOW, SSIM_SIGMA = 11, 1.5
SSIM_C1, SSIM_C2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2

# One GL context per thread, shared by that thread's renderers (see the module doc).
_THREAD = threading.local()
_CONTEXTS: list = []  # every shared context, to free them all before a fork
_GENERATION = [0]  # bumped when a fork freed them: threads then make new ones
_LIVE: weakref.WeakSet = weakref.WeakSet()  # every open renderer


def _thread_context():  # -> mujoco.GLContext
    gl, generation = getattr(_THREAD, "entry", (None, -1))
    if gl is None or generation != _GENERATION[0]:
        try:
            # Renderers draw into their own framebuffers: the context's own size is moot.
            gl = mujoco.GLContext(64, 64)
        except Exception as exc:  # GL set-up fails deep inside a driver: name the cause
            raise RuntimeError(
                f"cannot create an offscreen OpenGL context (MUJOCO_GL={BACKEND}): {exc}. "
                "Install Mesa EGL (libegl1 libegl-mesa0) or OSMesa, or set MUJOCO_GL to a "
                "working backend."
            ) from exc
        _THREAD.entry = (gl, _GENERATION[0])
        _CONTEXTS.append(gl)
    return gl


def _make_current(gl) -> None:  # gl: mujoco.GLContext
    """Make `gl` current unless it already is: asking EGL costs a fifth of eglMakeCurrent."""
    if BACKEND == "egl":
        current = sys.modules["mujoco.egl"].EGL.eglGetCurrentContext()
        if current and current.address == gl._context.address:
            return
    gl.make_current()


class OffscreenRenderer:
    """Render a model's cameras into RGB arrays of a fixed size.

    Args:
        model: the model (its ``vis.global_.offwidth/offheight`` must fit the size).
        height, width: frame size in pixels.
        shadows: draw shadows (costly on software GL).
    """

    def __init__(self, model: mujoco.MjModel, height: int, width: int, *,
                 shadows: bool = False) -> None:
        self.model = model
        self.height, self.width = height, width
        self._context = None
        self._gl = _thread_context()
        self._gl.make_current()
        self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50.value)
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 4 * model.ngeom))
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        self._option = mujoco.MjvOption()
        self._option.sitegroup[:] = 0  # sensor sites are not part of the world
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._raw = np.empty((height, width, 3), np.uint8)
        _LIVE.add(self)

    @property
    def closed(self) -> bool:
        return self._context is None

    def render(self, data: mujoco.MjData, camera: int, out: np.ndarray | None = None
               ) -> np.ndarray:
        """Render camera id `camera` into `out` (H, W, 3) uint8 (allocated if None)."""
        if self._context is None:
            raise RuntimeError("render() after close()")
        if out is None:
            out = np.empty((self.height, self.width, 3), np.uint8)
        _make_current(self._gl)
        # Renderers share the GL context: bind this one's framebuffer.
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._camera.fixedcamid = camera
        mujoco.mjv_updateScene(self.model, data, self._option, None, self._camera,
                               mujoco.mjtCatBit.mjCAT_ALL.value, self._scene)
        mujoco.mjr_render(self._rect, self._scene, self._context)
        mujoco.mjr_readPixels(self._raw, None, self._rect, self._context)
        cv2.flip(self._raw, 0, dst=out)  # OpenGL's rows run bottom-up
        return out

    def upload_hfield(self, hfield: int) -> None:
        """Send a heightfield changed in the model to the renderer."""
        self._gl.make_current()
        mujoco.mjr_uploadHField(self.model, self._context, hfield)

    def close(self) -> None:
        """Free the MuJoCo render context; safe to call more than once."""
        if self._context is not None:
            self._gl.make_current()
            self._context.free()
            self._context = None
        _LIVE.discard(self)

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # at interpreter exit EGL may already be torn down
            pass


def _release_gl_before_fork() -> None:
    for renderer in list(_LIVE):
        renderer.close()
    for gl in _CONTEXTS:
        gl.free()
    _CONTEXTS.clear()
    _GENERATION[0] += 1
    egl = sys.modules.get("mujoco.egl")
    if BACKEND == "egl" and egl is not None and egl.EGL_DISPLAY is not None:
        egl.EGL.eglTerminate(egl.EGL_DISPLAY)
        egl.EGL.eglReleaseThread()
        egl.EGL_DISPLAY = None  # the next context initialises a fresh display


os.register_at_fork(before=_release_gl_before_fork)


#: Frames enter the blurs shifted by mid-grey: squares stay small, so the float32 moments
#: lose less to cancellation in E[x^2] - E[x]^2 (SSIM of identical frames is 1 to 1e-7).
SHIFT = 128.0


# error_model="numpy": no division-by-zero check, so the loop vectorises (den >= c1 * c2 > 0).
@numba.njit(cache=True, nogil=True, fastmath=True, error_model="numpy")
def _ssim_mean(mu_x: np.ndarray, mu_y: np.ndarray, xx: np.ndarray, yy: np.ndarray,
               xy: np.ndarray, r: int) -> float:
    """Mean SSIM map from the blurred moments of the shifted frames, over the positions
    where the whole window fits."""
    h, w = mu_x.shape
    if h <= 2 * r or w <= 2 * r:
        r = 0
    c1, c2 = np.float32(SSIM_C1), np.float32(SSIM_C2)
    two, shift = np.float32(2.0), np.float32(SHIFT)
    total = 0.0
    for i in range(r, h - r):
        ax, ay, axx = mu_x[i, r:w - r], mu_y[i, r:w - r], xx[i, r:w - r]
        ayy, axy = yy[i, r:w - r], xy[i, r:w - r]
        row = np.float32(0.0)  # float32 within a row vectorises; rows add up in float64
        for j in range(ax.size):
            a, b = ax[j], ay[j]  # shifted means: (co)variances need no shift back
            lum_a, lum_b = a + shift, b + shift
            num = (two * lum_a * lum_b + c1) * (two * (axy[j] - a * b) + c2)
            den = (lum_a * lum_a + lum_b * lum_b + c1) * ((axx[j] - a * a)
                                                          + (ayy[j] - b * b) + c2)
            row += num / den
        total += row
    return total / ((h - 2 * r) * (w - 2 * r))


class SSIMStream:
    """SSIM of each grey frame with the previous one (NaN for the first of a stream)."""

    def __init__(self, height: int, width: int) -> None:
        def buf() -> np.ndarray:
            return np.empty((height, width), np.float32)

        self._x, self._mu_x, self._xx = buf(), buf(), buf()
        self._y, self._mu_y, self._yy = buf(), buf(), buf()
        self._xy, self._tmp = buf(), buf()
        self._has_previous = False

    def reset(self) -> None:
        self._has_previous = False

    def push(self, grey: np.ndarray) -> float:
        """Add a (H, W) uint8 frame; return its SSIM with the previous frame."""
        np.subtract(grey, np.float32(SHIFT), out=self._y, casting="unsafe")
        self._blur(self._y, self._mu_y)
        np.multiply(self._y, self._y, out=self._tmp)
        self._blur(self._tmp, self._yy)
        value = float("nan")
        if self._has_previous:
            np.multiply(self._x, self._y, out=self._tmp)
            self._blur(self._tmp, self._xy)
            value = _ssim_mean(self._mu_x, self._mu_y, self._xx, self._yy, self._xy,
                               SSIM_WINDOW // 2)
        # The new frame becomes the previous one: swap buffers, keep its blurred moments.
        self._x, self._y = self._y, self._x
        self._mu_x, self._mu_y = self._mu_y, self._mu_x
        self._xx, self._yy = self._yy, self._xx
        self._has_previous = True
        return value

    @staticmethod
    def _blur(src: np.ndarray, dst: np.ndarray) -> None:
        cv2.GaussianBlur(src, (SSIM_WINDOW, SSIM_WINDOW), SSIM_SIGMA, dst=dst,
                         borderType=cv2.BORDER_REFLECT)
