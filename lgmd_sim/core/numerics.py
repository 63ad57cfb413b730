"""The numeric mode: which machine code computes an episode, so that it gives the same bits
on any x86-64 processor with AVX2 ("replay", the default), or the fastest this processor
has ("host", ``LGMD_SIM_NUMERICS=host``).

NumPy picks its SIMD kernels when it is imported, by the processor: AVX-512 kernels on one,
AVX2 kernels on another, and they round differently. Measured on an AMD EPYC with AVX-512:
the demo's LoomSteer episode (`lgmd_sim.apps.defaults`) computes other potentials from its
4th frame on under NumPy's AVX-512 kernels than under its AVX2 ones, the frames and the
world the same; a controller that steers by the potentials every frame turns that into
another episode. "replay" disables NumPy's kernels above x86-64-v3 (AVX2, FMA)
(``NPY_DISABLE_CPU_FEATURES``) and gives Mesa's software renderer 256-bit vectors
(``LP_NATIVE_VECTOR_WIDTH``). The LGMD kernels (Numba) need no pin: they are compiled
without the fast-maths that reorders arithmetic (`lgmd_sim.models.kernels.JIT`), so the
code built for any processor computes the same operations in the same order (measured: the
same episode, bit for bit, compiled for this AMD EPYC's AVX-512 and for Haswell's AVX2).

Each variable is read by its library once, when it is imported or starts, so `pin` runs
first thing in ``import lgmd_sim`` (before it imports NumPy) and the worker processes
inherit them (Ray's, through the runtime environment); a process that imported NumPy
before lgmd-sim keeps its kernels, and `mode` says so. Results record the mode they ran in
(`lgmd_sim.core.machine`).
"""

from __future__ import annotations

import os
import platform
import sys

__all__ = ["MODES", "VARIABLE", "mode", "pin", "pinned_environment", "wanted"]

#: The variable that chooses the mode, and the modes.
VARIABLE = "LGMD_SIM_NUMERICS"
MODES = ("replay", "host")
#: NumPy's dispatch targets above x86-64-v3: the groups of NumPy 2 and the features of
#: NumPy 1 (a name a version does not know is ignored by it).
_ABOVE_V3 = ("X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX512F", "AVX512CD", "AVX512_KNL",
             "AVX512_KNM", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL")


def wanted() -> str:
    """The mode `VARIABLE` asks for (unset: "replay").

    Raises:
        ValueError: a value that is no mode, in one line (`pin` takes it for "replay").
    """
    value = os.environ.get(VARIABLE, "").strip().lower() or MODES[0]
    if value not in MODES:
        raise ValueError(f"{VARIABLE}={value}: give one of {', '.join(MODES)}")
    return value


def pinned_environment() -> dict[str, str]:
    """The environment variables of the replay mode (on x86-64; none elsewhere), as a
    process that runs episodes must have them before it imports NumPy."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return {}
    disabled = os.environ.get("NPY_DISABLE_CPU_FEATURES", "").replace(",", " ").split()
    return {"NPY_DISABLE_CPU_FEATURES": " ".join(dict.fromkeys([*disabled, *_ABOVE_V3])),
            "LP_NATIVE_VECTOR_WIDTH": "256"}


def pin() -> None:
    """In the replay mode, set `pinned_environment` in this process (and so in the workers
    it starts), unless NumPy is imported already (then `mode` is "host")."""
    try:
        host = wanted() == "host"
    except ValueError:  # said in one line by the command (lgmd_sim.cli), not at import
        host = False
    if not host and "numpy" not in sys.modules:
        os.environ.update(pinned_environment())


def mode() -> str:
    """The mode this process computes in: "replay" where NumPy's kernels are the pinned
    ones (or the processor is not x86-64, where nothing is pinned), else "host"."""
    if not pinned_environment():
        return MODES[0]
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:  # NumPy 1
        from numpy.core._multiarray_umath import __cpu_features__ as features
    # NumPy 2 dispatches by groups (X86_V3 ...), NumPy 1 by features
    above = ("X86_V4", "AVX512_ICL", "AVX512_SPR") if "X86_V3" in features else ("AVX512F",)
    pinned = features.get("X86_V3", features.get("AVX2", False)) and not any(
        features.get(name, False) for name in above)
    return MODES[0] if pinned else MODES[1]
