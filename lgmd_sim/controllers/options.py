"""The options every job shares, parsed and checked in one place.

Parsers turn a command line's text into values ("0,1,2" -> jitter levels, "all" -> every
scenario, "lgmd1/calibrated+image" -> a detector); checks hold a job's typed
configuration to the same rules when it is made in Python. Each raises a one-line
ValueError that names the option and the bad value, so that a bad option fails before
any work starts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from lgmd_sim.core.params import comma_list

__all__ = [
    "check_detectors",
    "check_jitter",
    "check_noise_levels",
    "check_positive",
    "check_range",
    "check_seed",
    "comma_list",
    "detectors",
    "file_key",
    "jitter_levels",
    "model_names",
    "names",
    "noise_levels",
    "resolution",
]


def names(text: str | Iterable[str], valid: Sequence[str], what: str, *,
          drop_repeats: bool = True, load: Callable[[str], Any] | None = None) -> list[str]:
    """Names from a comma-separated list (or a sequence), each among `valid`; "all" is
    every one (and listed among them in the message); order kept.

    Args:
        what: the kind of name, for the message ("scenario(s)").
        drop_repeats: drop a name given twice; False keeps it, for a configuration whose
            own check refuses it (a dataset's).
        load: for names that may also be a plug-in's "package.module:Class" spec: a name
            outside `valid` holding ':' is accepted if ``load(name)`` returns (it raises
            the one-line ValueError of a bad spec), so that it fails here, before any work.
    """
    given = comma_list(text) if isinstance(text, str) else [str(t) for t in text]
    if given == ["all"]:
        return list(valid)
    unknown = [n for n in given if n not in valid and not (load and ":" in n)]
    if unknown or not given:
        problem = f"unknown {what} {', '.join(map(repr, unknown))}" if unknown else (
            f"no {what} given")
        raise ValueError(f"{problem}; valid: all, {', '.join(valid)}")
    if load:
        for n in given:
            if n not in valid:
                load(n)
    return list(dict.fromkeys(given)) if drop_repeats else given


def file_key(name: str) -> str:
    """`name` as part of a file name: a plug-in's "package.module:Class" gives
    "package.module_Class", as ':' is no file-name character on every system."""
    return name.replace(":", "_")


def _jitter_error(shown: str, option: str = "--jitter") -> ValueError:
    from lgmd_sim.world.params import MAX_JITTER

    return ValueError(f"{option}: jitter level {shown} is not a number in [0, {MAX_JITTER:g}]")


def _is_jitter(level: Any) -> bool:
    from lgmd_sim.world.params import MAX_JITTER

    return (isinstance(level, int | float) and not isinstance(level, bool)
            and 0 <= level <= MAX_JITTER)


def jitter_levels(text: str, *, drop_repeats: bool = True) -> tuple[float, ...]:
    """Jitter levels from "0,1,2", order kept (repeats dropped unless `drop_repeats` is
    False, as in `names`)."""
    levels = []
    for item in text.split(","):
        try:
            level = float(item)
        except ValueError:
            level = math.nan
        if not _is_jitter(level):
            raise _jitter_error(repr(item.strip()))
        levels.append(level)
    return tuple(dict.fromkeys(levels)) if drop_repeats else tuple(levels)


def check_jitter(levels: Sequence[float], option: str = "--jitter") -> None:
    """Jitter levels of a configuration: at least one, each in range, none twice (`option`:
    where they were given, for the message)."""
    if not levels:
        raise ValueError(f"{option}: no jitter levels given")
    for level in levels:
        if not _is_jitter(level):
            raise _jitter_error(repr(level), option)
    if len(set(levels)) < len(levels):
        raise ValueError(f"{option}: a level is given twice: {', '.join(map(str, levels))}")


def noise_levels(text: str) -> tuple[float, ...]:
    """Noise levels (Gaussian variances, salt-and-pepper densities) from "0.001,0.005",
    each in (0, 1]; "" is none."""
    levels = []
    for item in comma_list(text):
        try:
            level = float(item)
        except ValueError:
            level = -1.0
        if not _is_noise_level(level):
            raise _noise_level_error(repr(item))
        levels.append(level)
    return tuple(dict.fromkeys(levels))


def _is_noise_level(level: Any) -> bool:
    return isinstance(level, int | float) and not isinstance(level, bool) and 0 < level <= 1


def _noise_level_error(shown: str) -> ValueError:
    return ValueError(f"noise level {shown} is not a number in (0, 1]")


def check_noise_levels(levels: Sequence[float]) -> None:
    """Noise levels of a configuration: each in (0, 1]."""
    for level in levels:
        if not _is_noise_level(level):
            raise _noise_level_error(repr(level))


def check_positive(value: Any, option: str, *, integer: bool = False) -> None:
    """A finite number > 0 (an integer >= 1 with `integer`)."""
    if integer:
        if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
            raise ValueError(f"{option} must be a positive integer, got {value!r}")
    elif not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ValueError(f"{option} must be a number > 0, got {value!r}")


def check_seed(value: Any, option: str) -> None:
    """A seed: an integer >= 0."""
    if not (isinstance(value, int) and not isinstance(value, bool) and value >= 0):
        raise ValueError(f"{option} must be an integer >= 0, got {value!r}")


def resolution(value: str | Sequence[int], option: str = "--resolution"
               ) -> str | tuple[int, int]:
    """A frame size, checked (`lgmd_sim.world.params.parse_resolution`): a preset name
    (`lgmd_sim.world.params.RESOLUTIONS`), "HEIGHTxWIDTH" or (height, width)."""
    from lgmd_sim.world.params import parse_resolution

    return parse_resolution(value, option)


def check_range(value: Any, option: str, lo: float, hi: float) -> None:
    """A number in [lo, hi]."""
    if not (isinstance(value, int | float) and lo <= value <= hi):
        raise ValueError(f"{option} must be in [{lo:g}, {hi:g}], got {value!r}")


def model_names(spec: str | Sequence[str]) -> list[str]:
    """Model names from "all", a comma-separated list, or a sequence, each a name of
    `lgmd_sim.models.available()` or a "package.module:Class" spec; unknown names and
    bad specs fail."""
    from lgmd_sim import models

    given = spec if isinstance(spec, str) else [n.strip() for n in spec if n.strip()]
    return names(given, models.available(), "model(s)", load=models.model_class)


def controller_names(spec: str | Sequence[str], what: str = "controller(s)") -> list[str]:
    """Controller names from "all", a comma-separated list, or a sequence, each a name of
    `lgmd_sim.controllers.available()` or a "package.module:Class" spec; unknown names and
    bad specs fail."""
    from lgmd_sim import controllers

    return names(spec, controllers.available(), what, load=controllers.controller_class)


def detectors(models_text: str | Sequence[str], presets_text: str | None = None
              ) -> tuple[tuple[str, str], ...]:
    """(model, preset) pairs from a list of detectors ("all", or each MODEL or
    MODEL/PRESET, optionally with front ends: `lgmd_sim.models.parse_spec`) and a list of
    presets: a model listed without a preset runs each of those it has (its default when
    it has none of them)."""
    from lgmd_sim import models

    tokens = comma_list(models_text) if isinstance(models_text, str) else list(models_text)
    if tokens == ["all"]:
        tokens = models.available()
    presets = comma_list(presets_text or "")
    found = []
    for token in tokens:
        name, preset = models.parse_spec(token)
        have = [p for p in presets if p in models.presets_of(name)]
        found += ([(name, p) for p in have] if have and "/" not in token
                  else [(name, preset)])
    if presets and not any(p in models.presets_of(n) for n, _ in found for p in presets):
        raise ValueError(f"no model listed has any of the presets {', '.join(presets)}")
    if not found:
        raise ValueError("no models given")
    return tuple(dict.fromkeys(found))


def check_detectors(pairs: Sequence[Sequence[str]]) -> tuple[tuple[str, str], ...]:
    """(model, preset) pairs of a configuration, each a detector `lgmd_sim.models`
    builds, as tuples."""
    from lgmd_sim import models

    if not pairs:
        raise ValueError("no models given")
    out = []
    for pair in pairs:
        if len(pair) != 2:
            raise ValueError(f"a detector is (model, preset), got {pair!r}")
        out.append(models.parse_spec(f"{pair[0]}/{pair[1]}"))
    return tuple(out)
