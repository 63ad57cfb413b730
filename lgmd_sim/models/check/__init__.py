"""Is a model sound? `check_model` runs a model through the contract of `LGMDModel`, as
Gymnasium's ``check_env`` does for environments, and raises a `ModelCheckError` naming
the first thing wrong, or returns what it checked and skipped.

The checks (`CHECKS`, in the order they run; each assumes those before it passed) feed
the model seeded synthetic frames (`looming_frames`: a dark disc looming over a textured
background), uint8 and then float, and compare runs the contract says are equal, bit for
bit: two fresh models, a batch and its streams run alone, a reset model and a fresh one.
Most faults show as one of those differences, so each check compares as little as it can
and its message says which part of the contract the difference breaks.

The checks are grouped by what they look at: what the class declares
(`lgmd_sim.models.check.declaration`), how it steps (`.stepping`) and its state maps
under the front ends (`.front_ends`); the probe clips and the runs they compare are in
`.probe`.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable

from lgmd_sim import models
from lgmd_sim.models.base import LGMDModel, ModelParams
from lgmd_sim.models.check.declaration import _class, _parameters, _search_space
from lgmd_sim.models.check.front_ends import _front_ends
from lgmd_sim.models.check.probe import _N, ModelCheckError, _Subject, looming_frames
from lgmd_sim.models.check.stepping import (
    _determinism,
    _frame_size,
    _layers,
    _potentials,
    _reset,
    _streaming,
)
from lgmd_sim.models.guard import PluginError

__all__ = ["CHECKS", "PREFLIGHT", "ModelCheckError", "check_model", "looming_frames",
           "preflight"]


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
