"""The options every job shares, parsed and checked in one place.

Parsers turn a command line's text into values ("0,1,2" -> jitter levels, "all" -> every
scenario, "lgmd1/calibrated+image" -> a detector); checks (`lgmd_sim.core.params` checks,
held by `lgmd_sim.core.params.checked`) hold a job's typed configuration to the same rules
when it is made in Python. A bad value is a one-line ValueError that names the field and
the value (a `lgmd_sim.core.params.FieldError`: the command line names its option), so that
a bad option fails before any work starts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from lgmd_sim.core.params import FieldError, comma_list

__all__ = [
    "check_detectors",
    "comma_list",
    "controller_names",
    "detectors",
    "file_key",
    "jitter_levels",
    "jitter_list",
    "model_names",
    "names",
    "noise_list",
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


def _is_jitter(level: Any) -> bool:
    from lgmd_sim.world.params import MAX_JITTER

    return (isinstance(level, int | float) and not isinstance(level, bool)
            and 0 <= level <= MAX_JITTER)


def _jitter_range() -> str:
    from lgmd_sim.world.params import MAX_JITTER

    return f"must hold jitter levels in [0, {MAX_JITTER:g}]"


def jitter_list(levels: Any) -> str | None:
    """A `lgmd_sim.core.params` check of a configuration's jitter levels: at least one, each
    in range, none twice."""
    if not isinstance(levels, tuple | list) or not levels:
        return "must hold at least one jitter level"
    if not all(map(_is_jitter, levels)):
        return _jitter_range()
    return "must hold each level once" if len(set(levels)) < len(levels) else None


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
            raise FieldError("jitter", f"{_jitter_range()}, got {item.strip()!r}")
        levels.append(level)
    return tuple(dict.fromkeys(levels)) if drop_repeats else tuple(levels)


def _is_noise_level(level: Any) -> bool:
    return isinstance(level, int | float) and not isinstance(level, bool) and 0 < level <= 1


#: What `noise_list` asks of each level.
_NOISE_RANGE = "must hold noise levels in (0, 1]"


def noise_list(levels: Any) -> str | None:
    """A `lgmd_sim.core.params` check of noise levels (Gaussian variances, salt-and-pepper
    densities): each in (0, 1]."""
    ok = isinstance(levels, tuple | list) and all(map(_is_noise_level, levels))
    return None if ok else _NOISE_RANGE


def resolution(value: str | Sequence[int], field: str = "resolution"
               ) -> str | tuple[int, int]:
    """A frame size, checked (`lgmd_sim.world.params.parse_resolution`): a preset name
    (`lgmd_sim.world.params.RESOLUTIONS`), "HEIGHTxWIDTH" or (height, width)."""
    from lgmd_sim.world.params import parse_resolution

    return parse_resolution(value, field)


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
