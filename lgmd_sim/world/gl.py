"""Choose MuJoCo's offscreen OpenGL backend before mujoco is imported, then import it.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so every module of
`lgmd_sim.world` imports mujoco from here: ``from lgmd_sim.world.gl import mujoco``.

Order of choice: an explicit ``MUJOCO_GL`` set by the user wins; otherwise EGL (headless,
works with Mesa's software renderer and on GPUs) when its libraries load, else OSMesa when
libOSMesa loads. When the backend's library does not load, importing this module raises
OSError in one line naming it and the Debian/Ubuntu packages that bring it: PyOpenGL
would otherwise fail deep inside MuJoCo's import (``'NoneType' object has no attribute
'glGetError'``) or at the first frame.

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
import platform

import cv2

#: Per headless backend, the libraries PyOpenGL loads (each entry: alternatives, any one
#: will do) and the Debian/Ubuntu packages that bring them (README, "Offscreen rendering").
_NEEDS = {"egl": (("EGL",), ("OpenGL", "GL")), "osmesa": (("OSMesa",),)}
_PACKAGES = {"egl": "libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 libglx0",
             "osmesa": "libosmesa6"}

#: The values of ``MUJOCO_GL`` MuJoCo accepts for a backend on each system (as
#: mujoco.rendering.classic.gl_context lists them; case and spaces do not count). It
#: raises a bare RuntimeError deep inside its import for any other.
_BACKENDS = {"Linux": ("egl", "osmesa", "glfw", "glx"), "Windows": ("glfw", "wgl"),
             "Darwin": ("glfw", "cgl")}
#: Other values it accepts: the platform's default, or rendering off.
_SWITCHES = ("enable", "enabled", "on", "true", "1", "disable", "disabled", "off", "false",
             "0")


def _loads(name: str) -> bool:
    # find_library's path, then the names PyOpenGL itself tries (so that a library only on
    # LD_LIBRARY_PATH, which ldconfig does not list, counts as present, as it is for PyOpenGL)
    found = ctypes.util.find_library(name)
    base = f"lib{name}.so"
    for path in ([found] if found else []) + [base] + [f"{base}.{i}" for i in range(9, -1, -1)]:
        try:
            ctypes.CDLL(path)
        except OSError:
            continue
        return True
    return False


def _missing(backend: str) -> list[str]:
    """The libraries of `backend` that do not load, as "libX" or "libX or libY"."""
    return [" or ".join(f"lib{n}" for n in names)
            for names in _NEEDS.get(backend, ()) if not any(map(_loads, names))]


def choose_backend() -> str:
    """The backend to use: the user's ``MUJOCO_GL`` if set, else the first of "egl" and
    "osmesa" whose libraries load (none: "egl", which `check_backend` refuses)."""
    user = os.environ.get("MUJOCO_GL", "").strip().lower()  # as MuJoCo reads it
    if user:
        return user
    return next((b for b in ("egl", "osmesa") if not _missing(b)), "egl")


def check_backend(backend: str) -> None:
    """Raise ValueError (one line: the valid values) when `backend` is no value MuJoCo
    accepts, OSError (one line: the library, the packages) unless it can load, and
    ValueError when ``PYOPENGL_PLATFORM`` names another one."""
    user = bool(os.environ.get("MUJOCO_GL", "").strip())
    backends = _BACKENDS.get(platform.system(), ("glfw",))
    if backend.strip().lower() not in backends + _SWITCHES:
        headless = [b for b in backends if b in _NEEDS]
        raise ValueError(f"MUJOCO_GL={backend} is not a MuJoCo rendering backend: use "
                         + (f"{' or '.join(headless)} (offscreen, no display needed), or "
                            if headless else "")
                         + " or ".join(b for b in backends if b not in headless)
                         + " (needs a display), or unset MUJOCO_GL to let lgmd-sim choose")
    pyopengl = os.environ.get("PYOPENGL_PLATFORM", "").strip()
    if backend in _NEEDS and pyopengl and pyopengl.lower() != backend:
        chosen = "MUJOCO_GL" if user else "the one whose libraries load here"
        raise ValueError(f"PYOPENGL_PLATFORM={pyopengl} but MuJoCo's GL backend is {backend} "
                         f"({chosen}): unset PYOPENGL_PLATFORM or make the two agree")
    missing = _missing(backend)
    if not missing:
        return
    if user:
        other = "osmesa" if backend == "egl" else "egl"
        raise OSError(f"MUJOCO_GL={backend}: {', '.join(missing)} does not load (offscreen "
                      f"rendering); install it (Debian/Ubuntu: sudo apt-get install "
                      f"{_PACKAGES[backend]}) or choose another backend (MUJOCO_GL={other})")
    raise OSError(f"offscreen rendering needs EGL or OSMesa and neither loads "
                  f"({', '.join(missing + _missing('osmesa'))}); install one (Debian/Ubuntu: "
                  f"sudo apt-get install {_PACKAGES['egl']} for EGL, or "
                  f"{_PACKAGES['osmesa']} for OSMesa)")


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
check_backend(BACKEND)
os.environ["MUJOCO_GL"] = BACKEND
if BACKEND in ("egl", "osmesa"):
    # PyOpenGL must agree with MuJoCo's context type (check_backend refused a
    # PYOPENGL_PLATFORM that does not).
    os.environ.setdefault("PYOPENGL_PLATFORM", BACKEND)

import mujoco  # noqa: E402  (must follow the MUJOCO_GL choice above)

__all__ = ["BACKEND", "check_backend", "choose_backend", "mujoco"]
