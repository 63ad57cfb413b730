"""What every check of `lgmd_sim.models.check` runs a model on and compares: the probe
clips (`looming_frames`), the model under check with its frames (`_Subject`), runs of it
(`_run`) and where two runs differ, bit for bit (`_first_difference`, `_same`), and the
error a failed check raises (`ModelCheckError`).

The underscored names are private to the `lgmd_sim.models.check` package: the checks in
its other modules share them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from functools import cached_property
from typing import Any

import numpy as np

from lgmd_sim.models.base import LGMDModel, ModelParams

__all__ = ["ModelCheckError", "looming_frames"]

#: Streams of the batches the checks run: 3, so that a stream has neighbours on each side.
_N = 3


class ModelCheckError(ValueError):
    """A model breaks the contract of `LGMDModel`: one line naming the model, the check
    and what is wrong."""


def looming_frames(streams: int, count: int, size: tuple[int, int], seed: int) -> np.ndarray:
    """`streams` sequences of `count` uint8 frames, (streams, count, H, W): a dark disc
    looming (its radius growing as 1 / time to contact, to half the frame) over a
    textured background, each stream with its own texture and disc centre."""
    rng = np.random.default_rng(seed)
    height, width = size
    rows, cols = np.mgrid[0:height, 0:width]
    out = np.empty((streams, count, height, width), np.uint8)
    for s in range(streams):
        out[s] = rng.integers(90, 220, size, np.uint8)
        cy, cx = rng.uniform(0.35, 0.65, 2) * (height, width)
        for t in range(count):
            radius = 0.05 * min(size) / (1.0 - 0.9 * t / max(count - 1, 1))
            out[s, t][(rows - cy) ** 2 + (cols - cx) ** 2 <= radius ** 2] = 20
    return out


def _mixed(frames: np.ndarray) -> list[np.ndarray]:
    """Frames (T, ...) as a list, the later half as float frames in 0..1: the contract
    lets the dtype change within a stream."""
    half = len(frames) // 2
    return [f if t < half else f / 255.0 for t, f in enumerate(frames)]


@dataclasses.dataclass
class _Run:
    """A run's potentials, (T,) or (T, N), and each step's layers (copied) when asked."""

    potentials: np.ndarray
    layers: list[dict[str, np.ndarray]] | None


def _step(model: LGMDModel, frame: np.ndarray, **kwargs: Any) -> Any:
    """One step; a zero rotation for the front ends that need one each frame."""
    if model.rotation_key is not None:
        kwargs["rotation"] = np.zeros((len(frame), 3) if model.batched else 3)
    return model.step(frame, **kwargs)


def _run(model: LGMDModel, seq: Sequence[np.ndarray], *, layers: bool = False) -> _Run:
    outs = [_step(model, f, layers=layers) for f in seq]
    return _Run(np.array([o.potential for o in outs], np.float64),
                [{k: v.copy() for k, v in o.layers.items()} for o in outs] if layers else None)


def _first_difference(a: np.ndarray, b: np.ndarray) -> int | None:
    """The first frame (leading index) at which `a` and `b` differ, or None."""
    unequal = ~((a == b) | ((a != a) & (b != b)))  # NaN equals NaN: the same bits
    unequal = unequal.reshape(len(a), -1).any(axis=1)
    return int(np.argmax(unequal)) if unequal.any() else None


def _same(a: _Run, b: _Run) -> bool:
    return _first_difference(a.potentials, b.potentials) is None and all(
        np.array_equal(x[k], y[k]) for x, y in zip(a.layers or (), b.layers or (), strict=True)
        for k in x)


def _watch(model: LGMDModel, before: Callable[[np.ndarray, Any], None] | None = None,
           after: Callable[[Any], None] | None = None) -> None:
    """Call `before(grey, layers)` and `after(potentials)` around each `step_batch`."""
    inner = model.step_batch

    def step_batch(grey: np.ndarray, layers: Any) -> Any:
        if before is not None:
            before(grey, layers)
        potentials = inner(grey, layers)
        if after is not None:
            after(potentials)
        return potentials

    model.step_batch = step_batch  # type: ignore[method-assign]


def _fail(message: str) -> None:
    raise ModelCheckError(message)


@dataclasses.dataclass
class _Subject:
    """The model under check and its test frames."""

    cls: type[LGMDModel]
    make_params: Callable[[], ModelParams]
    frames: np.ndarray  # (_N, T, H, W) uint8
    seed: int

    @cached_property
    def params(self) -> ModelParams:
        return self.make_params()

    @property
    def size(self) -> tuple[int, int]:
        return self.frames.shape[2], self.frames.shape[3]

    def build(self, n: int | None = None, **changes: Any) -> LGMDModel:
        return self.cls(self.params.replace(**changes) if changes else self.params,
                        n_streams=n)

    def batch(self) -> list[np.ndarray]:
        return _mixed(self.frames.transpose(1, 0, 2, 3))

    def single(self, i: int) -> list[np.ndarray]:
        return _mixed(self.frames[i])
