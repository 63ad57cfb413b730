"""The check of a model's state maps (`_front_ends`): the front ends (image
stabilisation, brightness gain; `lgmd_sim.models.warp`) warp every map `state_maps()`
declares, the outputs follow the warped maps, and no undeclared frame-shaped state
carries over from frame to frame (`_undeclared`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from lgmd_sim.models.base import LGMDModel, StateMap
from lgmd_sim.models.check.probe import _fail, _Run, _run, _same, _step, _Subject, _watch
from lgmd_sim.models.warp import Motion

#: The motion the front-end checks warp by: a shift of 2 pixels right and 1 down.
_SHIFT = Motion(np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]]))
_STILL = Motion(np.eye(3))
_GAIN = 0.7


def _frame_shaped(a: Any, size: tuple[int, int]) -> bool:
    """An array laid out as frames: (..., H, W), or padded rows (..., H or more, W + 2)."""
    return isinstance(a, np.ndarray) and a.ndim >= 2 and (
        a.shape[-2:] == size or (a.shape[-1] == size[1] + 2 and a.shape[-2] >= size[0]))


def _front_ends(s: _Subject) -> str | None:
    """the front ends warp every declared state map and the outputs follow; no undeclared
    frame-shaped state changes between frames and affects later outputs (skipped for a
    model without state_maps)"""
    if not s.cls.has_state_maps():  # the optional hook: such a model runs without them
        return "no state_maps"
    seq, k, size = s.single(0), len(s.frames[0]) // 2, s.size
    no_front_end = {"stabilize": "none", "gain": False}  # so that motion= may be given
    model = s.build(**no_front_end)
    _run(model, seq[:k])
    maps: list[StateMap] = list(model.state_maps())
    for m in maps:
        a = getattr(model, m.attr, None) if isinstance(m, StateMap) else None
        if not isinstance(a, np.ndarray):
            _fail(f"state_maps() lists {m!r}, which is not a StateMap of an array attribute")
        if m.fill not in ("frame", "zero") or not _frame_shaped(a, size) or len(a) != 1:
            _fail(f"state map {m.attr} (shape {a.shape}, fill {m.fill!r}) is not an array of "
                  f"shape (N, ..., {size[0]}, {size[1]}) (or padded rows) filled with "
                  "'frame' or 'zero'")

    def entering(motion: Motion) -> tuple[dict[str, np.ndarray], _Run]:
        """The maps as step_batch finds them on frame k after `motion`, and the outputs."""
        model = s.build(**no_front_end)
        _run(model, seq[:k])
        seen: dict[str, np.ndarray] = {}

        def look(grey: np.ndarray, layers: Any) -> None:
            for m in model.state_maps():
                a = getattr(model, m.attr)
                seen[m.attr] = (a[..., :size[0], 1:size[1] + 1] if m.padded is not None
                                else a).copy()

        _watch(model, before=look)
        return seen, _one(model, seq[k], motion)

    still_maps, still = entering(_STILL)
    moved_maps, moved = entering(_SHIFT)
    for attr, a in still_maps.items():
        if (a != a.flat[0]).any() and np.array_equal(a, moved_maps[attr]):
            _fail(f"state map {attr} does not move with a motion (a shift of 2 pixels): the "
                  "front ends cannot warp it")
    if _same(still, moved):
        _fail("a motion (a shift of 2 pixels) changes none of the outputs: the model does not "
              "read its warped maps (kept references from before the warp? read them "
              "through self)")
    frames = [m.attr for m in maps if m.fill == "frame"]
    if frames and _same(still, entering(Motion(gain=_GAIN))[1]):
        _fail(f"a brightness gain ({_GAIN}) changes none of the outputs: the model does not "
              f"read its scaled previous frame {frames[0]} (a reference from before the base "
              "made it float32? read maps through self)")
    _undeclared(s, {m.attr for m in maps}, no_front_end)
    return None


def _one(model: LGMDModel, frame: np.ndarray, motion: Motion) -> _Run:
    out = _step(model, frame, layers=True, motion=motion)
    return _Run(np.array([out.potential]), [{k: v.copy() for k, v in out.layers.items()}])


def _undeclared(s: _Subject, declared: set[str], no_front_end: dict[str, Any]) -> None:
    """Frame-shaped attributes that change from frame to frame and, overwritten with noise,
    change later outputs are state the front ends do not warp, unless `maps_moved`
    derives them afresh from the declared maps (a running sum)."""
    seq, k, size = s.single(0), len(s.frames[0]) // 2, s.size
    model = s.build(**no_front_end)
    _run(model, seq[:k - 1])
    before = {a: v.copy() for a, v in vars(model).items() if _frame_shaped(v, size)}
    _run(model, seq[k - 1:k])
    changing = [a for a, v in vars(model).items() if a not in declared and a in before
                and _frame_shaped(v, size) and not np.array_equal(v, before[a])]
    rng = np.random.default_rng(s.seed)

    def rest(noisy: str | None) -> _Run:
        model = s.build(**no_front_end)
        _run(model, seq[:k])
        if noisy is not None:
            a = getattr(model, noisy)
            if a.dtype == bool:
                a[...] = rng.random(a.shape) < 0.5
            else:
                a[...] = rng.uniform(0, 255, a.shape).astype(a.dtype)
        model.maps_moved()
        return _run(model, seq[k:], layers=True)

    if changing:
        reference = rest(None)
        for attr in changing:
            if not _same(rest(attr), reference):
                _fail(f"state {attr} is frame-shaped but not declared in state_maps(), so the "
                      "front ends cannot warp it")
