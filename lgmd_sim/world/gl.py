"""Choose MuJoCo's offscreen OpenGL backend before mujoco is imported, then import it.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so every module of
`lgmd_sim.world` imports mujoco from here: ``from lgmd_sim.world.gl import mujoco``.

Order of choice: an explicit ``MUJOCO_GL`` set by the user wins; otherwise EGL (headless,
works with Mesa's software renderer and on GPUs) when libEGL loads, else OSMesa when
libOSMesa loads, else EGL anyway so that the error names the missing library.

Worker processes (vector environments) render with one Mesa software-rasteriser thread
each (``LP_NUM_THREADS=1`` unless set) and run OpenCV single-threaded: the parallelism
comes from the workers, and n workers then keep n cores busy instead of fighting over
them. The main process keeps the defaults (all cores). GPU drivers ignore the variable.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import multiprocessing
import os

import cv2


def _loads(name: str) -> bool:
    path = ctypes.util.find_library(name)
    if path is None:
        return False
    try:
        ctypes.CDLL(path)
    except OSError:
        return False
    return True


def choose_backend() -> str:
    """The backend to use: the user's ``MUJOCO_GL`` if set, else "egl", else "osmesa"."""
    user = os.environ.get("MUJOCO_GL", "").strip()
    if user:
        return user
    if _loads("EGL"):
        return "egl"
    if _loads("OSMesa"):
        return "osmesa"
    return "egl"


def _single_threaded_worker() -> None:
    os.environ.setdefault("LP_NUM_THREADS", "1")
    cv2.setNumThreads(1)


if multiprocessing.parent_process() is not None:  # a spawned or forkserver worker
    _single_threaded_worker()

# A forked worker inherits OpenCV's thread pool as it was at the fork. Reconfiguring it in
# the child can deadlock on a pool lock some parent thread held at that instant, so the
# parent makes it single-threaded just before forking and restores it just after. Mesa
# reads LP_NUM_THREADS when the child makes its GL context (after the fork, see render).
_parent_threads: list[int] = []


def _before_fork() -> None:
    _parent_threads.append(cv2.getNumThreads())
    cv2.setNumThreads(1)


def _after_fork_in_parent() -> None:
    cv2.setNumThreads(_parent_threads.pop())


def _after_fork_in_child() -> None:
    _parent_threads.clear()
    os.environ.setdefault("LP_NUM_THREADS", "1")


os.register_at_fork(before=_before_fork, after_in_parent=_after_fork_in_parent,
                    after_in_child=_after_fork_in_child)

BACKEND = choose_backend()
os.environ["MUJOCO_GL"] = BACKEND
if BACKEND in ("egl", "osmesa"):
    # PyOpenGL must agree with MuJoCo's context type; a user's explicit choice stays.
    os.environ.setdefault("PYOPENGL_PLATFORM", BACKEND)

import mujoco  # noqa: E402  (must follow the MUJOCO_GL choice above)

__all__ = ["BACKEND", "choose_backend", "mujoco"]
