"""The checks of stepping, the streaming and batched contract of `LGMDModel`: valid
potentials (`_potentials`), determinism, the layers, a batch equal to its streams run
alone (`_streaming`), reset and a change of frame size.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from lgmd_sim.models.check.probe import (
    _N,
    _fail,
    _first_difference,
    _mixed,
    _run,
    _step,
    _Subject,
    _watch,
    looming_frames,
)
from lgmd_sim.models.guard import potentials_fault


def _potentials(s: _Subject) -> None:
    """potentials are finite, one per stream, in the range the alarm threshold takes, a
    new array each step"""
    model = s.build(_N)
    returned: list[Any] = []
    threshold = s.cls.Params.__dataclass_fields__["threshold"].metadata["check"]

    def keep(potentials: Any) -> None:  # before the base's own check: frame and stream
        t = len(returned)
        fault = potentials_fault(potentials, _N, threshold, t)
        if fault:
            _fail(fault)
        if any(potentials is r for r, _ in returned):
            _fail(f"step_batch returned the same array at frame {t} as before: return a new "
                  "array each step")
        returned.append((potentials, potentials.copy()))

    _watch(model, after=keep)
    _run(model, s.batch())
    for t, (now, then) in enumerate(returned):
        changed = _first_difference(now, then)
        if changed is not None:
            _fail(f"the potentials returned at frame {t} changed later (stream {changed}: "
                  f"{float(then[changed])!r}, now {float(now[changed])!r}): step_batch must "
                  "return a new array each step, not one the model writes into later")


def _determinism(s: _Subject) -> None:
    """two fresh models give the same outputs on the same frames, stepped apart or in
    turn"""
    seq = s.single(0)
    alone = _run(s.build(), seq).potentials
    again = _run(s.build(), seq).potentials
    t = _first_difference(alone, again)
    if t is not None:
        _fail(f"two fresh models give different potentials on the same frames (frame {t}: "
              f"{float(alone[t])!r}, {float(again[t])!r}): does the model draw unseeded "
              "random numbers?")
    a, b = s.build(), s.build()
    turns = np.array([[_step(m, f).potential for m in (a, b)] for f in seq])
    t = _first_difference(turns, np.stack([alone, alone], axis=1))
    if t is not None:
        _fail(f"two models stepped in turn differ from one stepped alone (frame {t}): they "
              "share state (a class attribute, a module global?)")


def _layers(s: _Subject) -> None:
    """step(layers=True) fills every layer of layer_names at frame size and leaves the
    potentials as they are"""
    model = s.build(_N)

    def unwritten(grey: np.ndarray, layers: Any) -> None:
        for a in (layers or {}).values():
            a.fill(np.nan)  # what step_batch leaves of it shows as NaN

    _watch(model, before=unwritten)
    seq = s.batch()
    run = _run(model, seq, layers=True)
    names, shape = s.cls.layer_names, (_N, *s.size)
    for t, maps in enumerate(run.layers or ()):
        extra = sorted(set(maps) - set(names))
        if extra:
            _fail(f"step_batch added layer(s) {', '.join(extra)}, not in layer_names {names}")
        for name in names:
            a = maps[name]
            if a.shape != shape:
                _fail(f"layer {name} at frame {t} has shape {a.shape}, not {shape}")
            bad = int((~np.isfinite(a)).sum())
            if bad:
                _fail(f"layer {name} at frame {t} is not filled in full: {bad} of {a.size} "
                      "cells unwritten or not finite")
    t = _first_difference(run.potentials, _run(s.build(_N), seq).potentials)
    if t is not None:
        _fail(f"asking for layers changes the potentials (frame {t})")


def _streaming(s: _Subject) -> None:
    """a batch of streams gives, bit for bit, what each stream gives alone"""
    batch = _run(s.build(_N), s.batch(), layers=True)
    for i in range(_N):
        alone = _run(s.build(), s.single(i), layers=True)
        t = _first_difference(batch.potentials[:, i], alone.potentials)
        if t is not None:
            _fail(f"stream {i} of a batch of {_N} differs from the same frames run alone at "
                  f"frame {t} (potential {float(batch.potentials[t, i])!r} batched, "
                  f"{float(alone.potentials[t])!r} alone)")
        for name in s.cls.layer_names:
            t = _first_difference(np.stack([m[name][i] for m in batch.layers or ()]),
                                  np.stack([m[name] for m in alone.layers or ()]))
            if t is not None:
                _fail(f"layer {name} of stream {i} of a batch of {_N} differs from the same "
                      f"frames run alone at frame {t}")


def _reset(s: _Subject) -> None:
    """reset() gives a fresh model, reset(streams) fresh streams and leaves the others
    as they were"""
    seq = s.single(0)
    fresh = _run(s.build(), seq).potentials
    model = s.build()
    _run(model, s.single(1))
    model.reset()
    t = _first_difference(_run(model, seq).potentials, fresh)
    if t is not None:
        _fail(f"after reset() the potentials differ from a fresh model's at frame {t}: "
              "allocate or reset_streams leaves state of the frames before behind")
    # a stream reset early may still be at rest (a slow model): reset it late too
    for k in (len(seq) // 3, 2 * len(seq) // 3):
        _reset_one(s, k)


def _reset_one(s: _Subject, k: int) -> None:
    """reset([1]) after `k` frames: stream 1 runs on as a fresh stream, 0 and 2 as before."""
    batch, frames = s.build(_N), s.batch()
    before = _run(batch, frames[:k]).potentials
    batch.reset([1])
    after = _run(batch, frames[k:]).potentials
    t = _first_difference(after[:, 1], _run(s.build(), [f[1] for f in frames[k:]]).potentials)
    if t is not None:
        _fail(f"after reset([1]) stream 1 differs from a fresh stream at frame {k + t}: "
              "reset_streams leaves some of its state as it was")
    for i in (0, 2):
        t = _first_difference(np.concatenate([before[:, i], after[:, i]]),
                              _run(s.build(), s.single(i)).potentials)
        if t is not None:
            _fail(f"reset([1]) changed stream {i} (frame {t}): reset_streams must touch only "
                  "the streams it is given")


def _frame_size(s: _Subject) -> None:
    """the frame size changes only after reset(): another size is refused before it, and
    runs as in a fresh model after it"""
    height, width = s.size
    other = _mixed(looming_frames(1, len(s.frames[0]), (height + 4, width + 6), s.seed + 1)[0])
    for n, taken in ((None, "without reset()"), (_N, "after reset(streams)")):
        model = s.build(n)
        _run(model, (s.batch() if n else s.single(0))[:3])
        if n:
            model.reset([0])
        try:
            _step(model, np.stack([other[0]] * n) if n else other[0])
        except ValueError:
            continue
        _fail(f"a frame of another size was taken {taken}: the frame size may change only "
              "on a full reset()")
    model = s.build()
    _run(model, s.single(0)[:3])
    model.reset()
    t = _first_difference(_run(model, other).potentials, _run(s.build(), other).potentials)
    if t is not None:
        _fail(f"after reset(), frames of {height + 4}x{width + 6} give other potentials than "
              f"in a fresh model (frame {t}): allocate must size all state from its arguments")
