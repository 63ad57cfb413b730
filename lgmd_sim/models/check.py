"""Is a model sound? `check_model` runs a model through the contract of `LGMDModel`, as
Gymnasium's ``check_env`` does for environments, and raises a `ModelCheckError` naming
the first thing wrong, or returns what it checked and skipped.

The checks (`CHECKS`, in the order they run; each assumes those before it passed) feed
the model seeded synthetic frames (`looming_frames`: a dark disc looming over a textured
background), uint8 and then float, and compare runs the contract says are equal, bit for
bit: two fresh models, a batch and its streams run alone, a reset model and a fresh one.
Most faults show as one of those differences, so each check compares as little as it can
and its message says which part of the contract the difference breaks.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from functools import cached_property
from typing import Any

import numpy as np

from lgmd_sim import models
from lgmd_sim.models.base import LGMDModel, ModelParams, StateMap, reserved_fault
from lgmd_sim.models.guard import PluginError, potentials_fault
from lgmd_sim.models.search import check_search_space, draw_search
from lgmd_sim.models.warp import Motion

__all__ = ["CHECKS", "PREFLIGHT", "ModelCheckError", "check_model", "looming_frames",
           "preflight"]

#: Streams of the batches the checks run: 3, so that a stream has neighbours on each side.
_N = 3
#: The motion the front-end checks warp by: a shift of 2 pixels right and 1 down.
_SHIFT = Motion(np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 1.0], [0.0, 0.0, 1.0]]))
_STILL = Motion(np.eye(3))
_GAIN = 0.7
#: Candidates the search-space check draws and builds.
_CANDIDATES = 5


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


# --- the checks ---------------------------------------------------------------------------


def _class(s: _Subject) -> None:
    """an LGMDModel subclass implementing the hooks, with name, layer_names, presets and
    Params"""
    cls = s.cls
    if not (isinstance(cls, type) and issubclass(cls, LGMDModel)):
        _fail(f"{cls!r} is not a subclass of LGMDModel")
    if inspect.isabstract(cls):
        _fail(f"it does not implement {', '.join(sorted(cls.__abstractmethods__))}")
    if not isinstance(getattr(cls, "name", None), str) or not cls.name:
        _fail("it has no name (a class attribute: the model's name in messages)")
    names = getattr(cls, "layer_names", None)
    if not (isinstance(names, tuple) and all(isinstance(n, str) and n for n in names)
            and len(set(names)) == len(names)):
        _fail(f"layer_names must be a tuple of distinct names (() for none), got {names!r}")
    presets = cls.presets
    if not (isinstance(presets, Mapping) and presets and all(
            isinstance(k, str) and isinstance(v, Mapping) for k, v in presets.items())):
        _fail("presets must map preset names to parameter overrides, the default first, "
              f"got {presets!r}")
    params = getattr(cls, "Params", None)
    if not (isinstance(params, type) and issubclass(params, ModelParams)
            and dataclasses.is_dataclass(params)):
        _fail(f"Params must be a dataclass subclassing ModelParams, got {params!r}")


def _parameters(s: _Subject) -> None:
    """every parameter has a default, a source and a check, which its default passes;
    every preset builds"""
    reserved = reserved_fault(s.cls.Params)
    if reserved:
        _fail(reserved)
    declare = "declare it with lgmd_sim.core.params.param(default, source, check=...)"
    for f in dataclasses.fields(s.cls.Params):
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            _fail(f"parameter {f.name} has no default: {declare}")
        source = f.metadata.get("source")
        if not (isinstance(source, str) and source.strip()):
            _fail(f"parameter {f.name} has no source (where its default comes from): {declare}")
        check = f.metadata.get("check")
        if not callable(check):
            _fail(f"parameter {f.name} has no check: {declare}")
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        error = check(default)
        if error:
            _fail(f"parameter {f.name}'s default {default!r} fails its own check: {error}")
    for preset, overrides in s.cls.presets.items():
        try:
            s.cls.Params(**overrides)
        except (TypeError, ValueError) as exc:
            _fail(f"preset {preset!r} does not build: {exc}")
    s.build()


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


def _search_space(s: _Subject) -> str | None:
    """the search_space names parameters, or every element of tuple ones, each a
    SearchRange, and its candidates build (skipped for a model without one)"""
    space = s.cls.search_space
    if isinstance(space, Mapping) and not space:
        return "no search_space"
    try:
        check_search_space(s.cls.name, s.cls.Params, space)
    except ValueError as exc:
        _fail(str(exc))
    rng, start = np.random.default_rng(s.seed), next(iter(s.cls.presets.values()))
    for _ in range(_CANDIDATES):
        drawn = draw_search(space, rng)
        try:
            s.cls.Params(**{**start, **drawn})
        except (TypeError, ValueError) as exc:
            _fail(f"the candidate {drawn} (the default preset with the drawn values) does "
                  f"not build: {exc}")
    return None


#: The checks, by name, in the order `check_model` runs them; each one's docstring says
#: what it asserts, and each returns None (passed) or why it was skipped.
CHECKS: dict[str, Callable[[_Subject], str | None]] = {
    "class": _class,
    "parameters": _parameters,
    "potentials": _potentials,
    "determinism": _determinism,
    "layers": _layers,
    "streaming = batched": _streaming,
    # before reset: a stale reference to a warped map shows in both, and the front ends'
    # message says why
    "front ends": _front_ends,
    "reset": _reset,
    "frame size": _frame_size,
    "search space": _search_space,
}


def check_model(model: type[LGMDModel] | str, *, frames: int = 24,
                size: tuple[int, int] = (24, 32), seed: int = 0,
                only: Collection[str] | None = None) -> list[tuple[str, str]]:
    """Check that a model keeps the contract of `LGMDModel` (`CHECKS`).

    Args:
        model: the class, or a model as `lgmd_sim.models.parse_spec` reads it: a name or
            a "package.module:Class" spec, with an optional preset and front ends
            ("lgmd1/plgmd+image"); a class is checked with its first preset.
        frames: frames per test sequence (at least 6).
        size: (height, width) of the test frames (at least 8 x 8).
        seed: seed of the test frames.
        only: the names of the checks to run (each assumes those before it in `CHECKS`
            passed); None: every one.

    Returns:
        What was checked: (the check's name, "passed" or "skipped: why") of every check
        run, in the order of `CHECKS`.

    Raises:
        ModelCheckError: on the first check that fails, one line naming the model, the
            check and what is wrong.
    """
    if not (isinstance(frames, int) and frames >= 6 and min(size) >= 8):
        raise ValueError(f"check_model needs frames >= 6 and a size of at least 8 x 8, got "
                         f"{frames} frames of {size}")
    unknown = set(only or ()) - set(CHECKS)
    if unknown:
        raise ValueError(f"no check {', '.join(sorted(unknown))}; checks: {', '.join(CHECKS)}")
    if isinstance(model, str):
        label = model
        try:  # a bad name, preset or front end is the spec's fault, not the model's
            name, preset = models.parse_spec(model)
        except ValueError as exc:
            raise ModelCheckError(f"{label}: {exc}") from None
        except Exception as exc:  # a class too broken to read its presets
            raise ModelCheckError(f"{label}: class: reading its presets raised "
                                  f"{type(exc).__name__}: {' '.join(str(exc).split())}"
                                  ) from exc
        cls = models.model_class(name)

        def make_params() -> ModelParams:
            return models.make(name, preset=preset).params
    else:
        cls = model
        label = f"{getattr(cls, '__module__', '?')}:{getattr(cls, '__qualname__', cls)}"

        def make_params() -> ModelParams:
            return cls.Params(**next(iter(cls.presets.values())))

    subject = _Subject(cls, make_params, looming_frames(_N, frames, size, seed), seed)
    done: list[tuple[str, str]] = []
    for title, check in CHECKS.items():
        if only is not None and title not in only:
            continue
        try:
            skipped = check(subject)
        except ModelCheckError as exc:
            raise ModelCheckError(f"{label}: {title}: {exc}") from None
        except PluginError as exc:  # raised through a hook: the check's own, or the base's
            own = exc.__cause__ if isinstance(exc.__cause__, ModelCheckError) else None
            raise ModelCheckError(f"{label}: {title}: {own or f'{exc.hook}: {exc.reason}'}"
                                  ) from None
        except Exception as exc:  # the model's own error: say where it came
            text = " ".join(str(exc).split())
            raise ModelCheckError(f"{label}: {title}: the model raised {type(exc).__name__}"
                                  f"{': ' + text if text else ''}") from exc
        done.append((title, "passed" if skipped is None else f"skipped: {skipped}"))
    return done


#: What a command checks of a plug-in detector before it starts (`preflight`): that it
#: builds and gives valid potentials, in a few milliseconds.
PREFLIGHT = ("class", "parameters", "potentials")


def preflight(detectors: Iterable[tuple[str, str]]) -> None:
    """Run the `PREFLIGHT` checks on every plug-in detector of `detectors` ((model, preset)
    pairs; the built-ins are checked by lgmd-sim's tests), so that a command refuses one
    that cannot run in one line before it makes its run folder, not minutes into it.

    Raises:
        ModelCheckError: the first check a plug-in fails, naming it.
    """
    for name, preset in dict.fromkeys(detectors):
        if models.origin(name) != "built-in":
            check_model(f"{name}/{preset}", only=PREFLIGHT)
