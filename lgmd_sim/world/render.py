"""Offscreen rendering of a camera and the streaming SSIM of consecutive frames.

`OffscreenRenderer` renders a model's cameras straight into reusable buffers, so that a
frame costs the GL work and one flip, nothing else. Its `draw` sends a frame to be
rasterised and returns at once; `read` waits for the pixels: work done between the two
overlaps the rasterisation (Mesa's software renderer rasterises in threads of its own, and
only starts when the frame is flushed). All renderers of a thread share one
OpenGL context (EGL or OSMesa, see `lgmd_sim.world.gl`), each with its own MuJoCo render
context: a new GL context costs a quarter of a second of shader compilation on Mesa's
software renderer, a MuJoCo context on an existing one a few milliseconds. Worker
processes (vector envs) each have their own. `SSIMStream` gives each new frame's SSIM
with the previous one in one numba pass over the frame (the previous frame's blurred
moments are kept), with the definition of `lgmd_sim.signals.metrics.ssim`.

Fork safety: a process forked after EGL was initialised hangs when it creates a context
(Mesa's driver state does not survive fork). So before any fork (``gym.make_vec(...,
vectorization_mode="async")`` forks by default on Linux) every renderer of this module is
closed, the shared contexts freed and the EGL display terminated; renderers are
re-created on their next frame, in the parent and in each child. GL contexts made
outside lgmd-sim in the same process do not survive a fork either.
"""

from __future__ import annotations

import ctypes
import os
import sys
import threading
import weakref

import cv2
import numba
import numpy as np

from lgmd_sim.core.stops import reraise_stop_from_ctypes
from lgmd_sim.world.gl import BACKEND, mujoco

# SSIM as lgmd_sim.signals.metrics.ssim (Wang et al. 2004): 11 x 11 Gaussian window, sigma 1.5,
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
            reraise_stop_from_ctypes(exc)
            raise RuntimeError(
                f"cannot create an offscreen OpenGL context (MUJOCO_GL={BACKEND}): {exc}. "
                "Install Mesa EGL (libegl1 libegl-mesa0) or OSMesa, or set MUJOCO_GL to a "
                "working backend."
            ) from exc
        _THREAD.entry = (gl, _GENERATION[0])
        _CONTEXTS.append(gl)
    return gl


def _gl_function(library: str, name: str, restype):  # -> a ctypes function, or None
    """`name` from the library PyOpenGL loaded for MuJoCo's backend, called straight
    through ctypes: PyOpenGL's wrapper (argument conversion, error check) costs twice the
    call. None where PyOpenGL has no such library (a backend with a window)."""
    try:
        from OpenGL import platform

        return ctypes.CFUNCTYPE(restype)((name, getattr(platform.PLATFORM, library)))
    except Exception:  # any failure: the callers fall back
        return None


_GL: dict[str, object] = {}  # resolved on first use, once MuJoCo has loaded PyOpenGL


def _gl(name: str):  # -> a ctypes function, or None
    if name not in _GL:
        _GL[name] = (_gl_function("EGL", name, ctypes.c_void_p) if name.startswith("egl")
                     else _gl_function("GL", name, None))
    return _GL[name]


def _make_current(gl) -> None:  # gl: mujoco.GLContext
    """Make `gl` current unless it already is: asking EGL costs a fifth of eglMakeCurrent."""
    if BACKEND == "egl":
        current = _gl("eglGetCurrentContext")
        if current is not None and current() == gl._context.address:
            return
    gl.make_current()


def _flush() -> None:
    """Start rasterising what was drawn (glFlush): Mesa's software renderer otherwise waits
    for the read of the pixels to begin."""
    flush = _gl("glFlush")
    if flush is not None:
        flush()


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
        self.draw(data, camera)
        return self.read(out)

    def draw(self, data: mujoco.MjData, camera: int) -> None:
        """Draw camera id `camera` in the state `data` and start its rasterisation; `read`
        gives the pixels. Nothing else may render on this thread in between."""
        if self._context is None:
            raise RuntimeError("render() after close()")
        _make_current(self._gl)
        # Renderers share the GL context: bind this one's framebuffer.
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._context)
        self._camera.fixedcamid = camera
        mujoco.mjv_updateScene(self.model, data, self._option, None, self._camera,
                               mujoco.mjtCatBit.mjCAT_ALL.value, self._scene)
        mujoco.mjr_render(self._rect, self._scene, self._context)
        _flush()
        _THREAD.drawn = weakref.ref(self)  # weak: a frame never read keeps no renderer alive

    def read(self, out: np.ndarray | None = None) -> np.ndarray:
        """The frame `draw` drew, into `out` (H, W, 3) uint8 (allocated if None)."""
        drawn = getattr(_THREAD, "drawn", None)
        if drawn is None or drawn() is not self:
            # the bound framebuffer is another renderer's: its pixels would be read
            raise RuntimeError("read() must follow this renderer's draw() on its thread")
        _THREAD.drawn = None
        if out is None:
            out = np.empty((self.height, self.width, 3), np.uint8)
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
        except Exception as exc:  # at interpreter exit EGL may already be torn down
            reraise_stop_from_ctypes(exc)  # but a stop that came in a GL call must stop us


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


#: The 1-D Gaussian of the SSIM window, as OpenCV's GaussianBlur samples it.
SSIM_TAPS = tuple(np.float32(t) for t in
                  cv2.getGaussianKernel(SSIM_WINDOW, SSIM_SIGMA, cv2.CV_64F).ravel())


# error_model="numpy": no division-by-zero check, so the loop vectorises (den >= c1 * c2 > 0).
@numba.njit(cache=True, nogil=True, fastmath=True, error_model="numpy")
def _ssim_push(grey: np.ndarray, previous: np.ndarray, mu_x: np.ndarray, xx: np.ndarray,
               mu_y: np.ndarray, yy: np.ndarray, has_previous: bool, taps: tuple) -> float:
    """Blur the moments of the shifted frame ``grey`` into ``mu_y`` and ``yy``, and return
    the mean SSIM map against the frame ``previous`` (blurred moments ``mu_x``, ``xx``);
    NaN without one. Then copy ``grey`` into ``previous``.

    The frames are (H, W) uint8, the blurred arrays (H - 2r, W - 2r) float32: only the
    positions where the whole window fits, so no border is read (small frames come padded).
    One output row at a time: the vertical sums of y, y^2 and x y over the full width into
    line buffers (in L1 cache), then the horizontal sums and the SSIM terms; the window is
    symmetric, so each tap weighs the sum of its two rows (columns).
    """
    h, w = grey.shape
    n = len(taps)
    r = n // 2
    ho, wo = h - 2 * r, w - 2 * r
    shift = np.float32(SHIFT)
    v_mu = np.empty(w, np.float32)
    v_sq = np.empty(w, np.float32)
    v_xy = np.empty(w, np.float32)
    h_xy = np.empty(wo, np.float32)
    c1, c2 = np.float32(SSIM_C1), np.float32(SSIM_C2)
    two = np.float32(2.0)
    total = 0.0
    for o in range(ho):
        t = taps[r]
        gy, gx = grey[o + r], previous[o + r]
        for j in range(w):
            b = np.float32(gy[j]) - shift
            v_mu[j] = t * b
            v_sq[j] = t * (b * b)
            v_xy[j] = t * ((np.float32(gx[j]) - shift) * b)
        for k in range(r):
            t = taps[k]
            gy, gx = grey[o + k], previous[o + k]
            gy2, gx2 = grey[o + n - 1 - k], previous[o + n - 1 - k]
            for j in range(w):
                b, b2 = np.float32(gy[j]) - shift, np.float32(gy2[j]) - shift
                v_mu[j] += t * (b + b2)
                v_sq[j] += t * (b * b + b2 * b2)
                v_xy[j] += t * ((np.float32(gx[j]) - shift) * b
                                + (np.float32(gx2[j]) - shift) * b2)
        amu, ayy, amx, axx = mu_y[o], yy[o], mu_x[o], xx[o]
        for j in range(wo):
            t = taps[r]
            m, s, c = t * v_mu[j + r], t * v_sq[j + r], t * v_xy[j + r]
            for k in range(r):
                t = taps[k]
                m += t * (v_mu[j + k] + v_mu[j + n - 1 - k])
                s += t * (v_sq[j + k] + v_sq[j + n - 1 - k])
                c += t * (v_xy[j + k] + v_xy[j + n - 1 - k])
            amu[j] = m
            ayy[j] = s
            h_xy[j] = c
        row = np.float32(0.0)  # float32 within a row vectorises; rows add up in float64
        for j in range(wo):
            a, m = amx[j], amu[j]  # shifted means: (co)variances need no shift back
            lum_a, lum_b = a + shift, m + shift
            num = (two * lum_a * lum_b + c1) * (two * (h_xy[j] - a * m) + c2)
            den = (lum_a * lum_a + lum_b * lum_b + c1) * ((axx[j] - a * a)
                                                          + (ayy[j] - m * m) + c2)
            row += num / den
        total += row
    previous[:] = grey
    if not has_previous:
        return np.nan
    return total / (ho * wo)


class SSIMStream:
    """SSIM of each grey frame with the previous one (NaN for the first of a stream)."""

    def __init__(self, height: int, width: int) -> None:
        r = SSIM_WINDOW // 2
        # A frame the window does not fit is padded as OpenCV's blur would (all averaged).
        self._pad = r if min(height, width) <= 2 * r else 0
        h, w = height + 2 * self._pad, width + 2 * self._pad
        self._previous = np.zeros((h, w), np.uint8)
        blurred = (h - 2 * r, w - 2 * r)
        self._mu_x, self._xx = np.empty(blurred, np.float32), np.empty(blurred, np.float32)
        self._mu_y, self._yy = np.empty(blurred, np.float32), np.empty(blurred, np.float32)
        self._shape = (height, width)
        self._has_previous = False

    def reset(self) -> None:
        self._has_previous = False

    def push(self, grey: np.ndarray) -> float:
        """Add a (H, W) uint8 frame; return its SSIM with the previous frame."""
        if grey.shape != self._shape or grey.dtype != np.uint8:
            raise ValueError(f"SSIMStream: expected a {self._shape} uint8 frame, got "
                             f"{grey.shape} {grey.dtype}")
        if self._pad:
            p = self._pad
            grey = cv2.copyMakeBorder(grey, p, p, p, p, cv2.BORDER_REFLECT)
        value = _ssim_push(grey, self._previous, self._mu_x, self._xx, self._mu_y, self._yy,
                           self._has_previous, SSIM_TAPS)
        # The new frame becomes the previous one: keep its blurred moments.
        self._mu_x, self._mu_y = self._mu_y, self._mu_x
        self._xx, self._yy = self._yy, self._xx
        self._has_previous = True
        return value
