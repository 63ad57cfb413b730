"""The interface every LGMD model shares: parameters, frame handling, streams and batches.

A model is streaming: ``step(frame)`` takes one frame and returns one `LGMDOutput`, with
all temporal state (previous frame, delayed inhibition, adaptation...) kept inside. The
same model runs N independent streams at once when built with ``n_streams=N``: then
``step`` takes frames of shape (N, H, W) or (N, H, W, 3) and returns arrays of N values,
identical to N separate streaming models.

Subclasses implement three hooks on a (N, H, W) stack of grey frames (uint8 in 0..255 or
float32 in 0..255): `_allocate` (state for a new frame size), `_reset_streams` (fresh
state for some streams) and `_step` (one frame per stream, returning potentials).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from lgmd_sim.frames import to_grey
from lgmd_sim.params import CheckedParams, in_range, param

# --- parameters -------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelParams(CheckedParams):
    """Base of every model's parameters: named, defaulted with a source, checked on creation."""

    threshold: float = param(
        0.8,
        "paper Sec. 4.1.3 (Eq. 23): membrane-potential threshold 0.8",
        check=in_range(0.5, 1.0),
        doc="alarm when the membrane potential exceeds this",
    )


# --- outputs ----------------------------------------------------------------------------


@dataclass(frozen=True)
class LGMDOutput:
    """One step's result: a float and a bool for a single stream, arrays of N for a batch.

    ``layers`` maps layer names (e.g. "P", "S", "D", "Phi") to maps of shape (H, W), or
    (N, H, W) for a batch; it is None unless ``step(..., layers=True)`` asked for it.
    """

    potential: float | np.ndarray
    alarm: bool | np.ndarray
    layers: Mapping[str, np.ndarray] | None = None


# --- models -----------------------------------------------------------------------------


class LGMDModel(ABC):
    """A looming detector: streaming, or N independent streams at once.

    Frames are grey (H, W) or RGB colour (H, W, 3), uint8 in 0..255 or float in 0..1;
    batched models take the same with a leading stream axis. The frame size is set by the
    first frame after construction or a full `reset` and must then stay the same.
    """

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]
    #: Names of the maps `step(..., layers=True)` returns, in the model's order.
    layer_names: ClassVar[tuple[str, ...]]
    #: Named parameter sets; the first is the default.
    presets: ClassVar[Mapping[str, Mapping[str, Any]]] = {"default": {}}

    def __init__(self, params: ModelParams | None = None, *, n_streams: int | None = None):
        if n_streams is not None and (
            not isinstance(n_streams, int | np.integer) or isinstance(n_streams, bool)
            or n_streams < 1
        ):
            raise ValueError(f"n_streams must be a positive integer or None, got {n_streams!r}")
        self.params = params if params is not None else self.Params()
        if not isinstance(self.params, self.Params):
            raise TypeError(f"{self.name} expects {self.Params.__name__}, got {type(params)}")
        self.n_streams = n_streams
        self._n = 1 if n_streams is None else int(n_streams)
        self.frame_shape: tuple[int, int] | None = None

    @property
    def batched(self) -> bool:
        return self.n_streams is not None

    def reset(self, streams: Sequence[int] | np.ndarray | None = None) -> None:
        """Start new streams: all of them (the frame size may then change), or those listed."""
        if streams is None:
            self.frame_shape = None
            return
        if not self.batched:
            raise ValueError("reset(streams=...) needs a batched model (n_streams=N)")
        idx = np.asarray(streams).reshape(-1)
        if idx.size and not np.issubdtype(idx.dtype, np.integer):  # 0.7 or True is no index
            raise ValueError(f"stream indices must be integers, got {np.asarray(streams)!r}")
        idx = idx.astype(np.intp)
        if idx.size and (idx.min() < 0 or idx.max() >= self._n):
            raise ValueError(f"stream index out of range 0..{self._n - 1}: {idx.tolist()}")
        if self.frame_shape is not None and idx.size:
            self._reset_streams(idx)

    def step(self, frame: np.ndarray, *, layers: bool = False) -> LGMDOutput:
        """Feed one frame (one per stream when batched); return potentials and alarms."""
        grey = self._to_grey_stack(frame)
        shape = (grey.shape[1], grey.shape[2])
        if self.frame_shape is None:
            self.frame_shape = shape
            self._allocate(self._n, *shape)
            self._reset_streams(np.arange(self._n))
        elif shape != self.frame_shape:
            raise ValueError(
                f"{self.name}: frame size {shape[0]}x{shape[1]} differs from this stream's "
                f"{self.frame_shape[0]}x{self.frame_shape[1]}; call reset() to start a new stream"
            )
        maps = {n: np.empty((self._n, *shape), np.float32) for n in self.layer_names} if (
            layers
        ) else None
        potential = self._step(grey, maps)
        alarm = potential > self.params.threshold
        if self.batched:
            return LGMDOutput(potential, alarm, maps)
        one = {k: v[0] for k, v in maps.items()} if maps else None
        return LGMDOutput(float(potential[0]), bool(alarm[0]), one)

    # -- hooks -------------------------------------------------------------------------

    @abstractmethod
    def _allocate(self, n: int, height: int, width: int) -> None:
        """Allocate the state of n streams of height x width frames."""

    @abstractmethod
    def _reset_streams(self, idx: np.ndarray) -> None:
        """Give the streams in idx the state of a new stream (no previous frame)."""

    @abstractmethod
    def _step(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        """Process grey frames (N, H, W) uint8 or float32 in 0..255; return N potentials.

        When ``layers`` is given, fill each of its (N, H, W) arrays with that layer's map.
        """

    # -- frames ------------------------------------------------------------------------

    def _to_grey_stack(self, frame: np.ndarray) -> np.ndarray:
        """Frames as a C-contiguous (N, H, W) uint8 or float32 (0..255) stack."""
        a = np.asarray(frame)
        lead = 1 if self.batched else 0
        what = "(N, H, W) or (N, H, W, 3)" if self.batched else "(H, W) or (H, W, 3)"
        if a.ndim == lead + 3 and a.shape[-1] == 1:
            a = a[..., 0]
        colour = a.ndim == lead + 3 and a.shape[-1] == 3
        if not (a.ndim == lead + 2 or colour):
            raise ValueError(f"{self.name}: expected frames of shape {what}, got {a.shape}")
        if self.batched and a.shape[0] != self._n:
            raise ValueError(
                f"{self.name}: expected {self._n} frames (one per stream), got {a.shape[0]}"
            )
        if min(a.shape[lead : lead + 2]) < 1:
            raise ValueError(f"{self.name}: empty frame of shape {a.shape}")
        if a.dtype == np.uint8:
            pass
        elif np.issubdtype(a.dtype, np.floating):
            if not np.isfinite(a).all():
                raise ValueError(f"{self.name}: frame contains NaN or infinite values")
            lo, hi = float(a.min()), float(a.max())
            if lo < 0.0 or hi > 1.0:
                raise ValueError(
                    f"{self.name}: float frames must lie in [0, 1], got values in [{lo:g}, {hi:g}]"
                    " (pass uint8 for 0..255 images)"
                )
            a = a.astype(np.float32) * np.float32(255.0)
        else:
            raise ValueError(f"{self.name}: frames must be uint8 or float, got {a.dtype}")
        if not self.batched:
            a = a[None]
        if colour:
            a = np.stack([to_grey(f) for f in a])
        return np.ascontiguousarray(a)
