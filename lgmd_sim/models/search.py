"""What the calibration searches of a model (`LGMDModel.search_space`): a `SearchRange`
per parameter (or per element of a tuple parameter), `check_search_space` to check a
declared space against the model's parameters, and `draw_search` to draw a candidate.

It lives with the models, below the calibration (`lgmd_sim.calibration.search`, which
runs the search): a model's class declares its space, and `check_model` checks it and
draws candidates to see that they build; the models do not import the jobs above them.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["SearchRange", "check_search_space", "draw_search"]


@dataclass(frozen=True)
class SearchRange:
    """How the calibration draws one value it searches (see `LGMDModel.search_space`):
    uniform in [low, high] (log-uniform with ``log``, the default: a scale), or one of
    ``choices``, each as likely.

    Attributes:
        times: the key of a value drawn before this one that multiplies it, so that one
            value stays above another (the feedback LGMD's second time constant is its
            first times U(1.5, 4)).
    """

    low: float | None = None
    high: float | None = None
    log: bool = True
    choices: tuple[Any, ...] = ()
    times: str | None = None

    def __post_init__(self) -> None:
        if self.choices:
            if self.low is not None or self.high is not None or self.times is not None:
                raise ValueError(f"{self}: either choices, or low and high (and times)")
            return
        real = all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                   for v in (self.low, self.high))
        if not (real and self.low < self.high and (self.low > 0 or not self.log)):
            raise ValueError(f"{self}: needs finite low < high (low > 0 when log), or "
                             "choices")

    def draw(self, rng: np.random.Generator) -> Any:
        """One value (before ``times``), by one draw of `rng`."""
        if self.choices:
            return self.choices[int(rng.choice(len(self.choices)))]
        if self.log:
            return float(np.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        return float(rng.uniform(self.low, self.high))


# A search-space key: a parameter, or one element of a tuple parameter ("eta[0]").
_SEARCH_KEY = re.compile(r"(\w+)(?:\[(\d+)\])?")


def check_search_space(model: str, params: type, ranges: Any) -> None:
    """Check a declared search space (`LGMDModel.search_space`) against the model's
    parameters `params` (its `ModelParams` dataclass): a mapping whose keys are
    parameters, or every element of a tuple parameter ("eta[0]", "eta[1]": indices 0 to
    its length - 1, the parameter not named bare as well); each value a `SearchRange`
    whose ``times`` is a key drawn before it.

    Raises:
        ValueError: one line naming `model` and the key at fault.
    """
    if not isinstance(ranges, Mapping):
        raise ValueError(f"model {model!r}: search_space must map parameters to "
                         f"SearchRanges, got {ranges!r}")
    defaults = {f.name: f.default for f in dataclasses.fields(params)}
    indices: dict[str, list[int | None]] = {}
    for i, (key, r) in enumerate(ranges.items()):
        where = f"model {model!r}: search_space key {key!r}"
        match = _SEARCH_KEY.fullmatch(key) if isinstance(key, str) else None
        if match is None or match.group(1) not in defaults:
            raise ValueError(f"{where} is no parameter (or 'parameter[i]') of the model")
        if not isinstance(r, SearchRange):
            raise ValueError(f"{where}: {r!r} is not a SearchRange")
        if r.times is not None and r.times not in list(ranges)[:i]:
            raise ValueError(f"{where}: times={r.times!r} is no key drawn before it")
        name, index = match.group(1), match.group(2)
        indices.setdefault(name, []).append(None if index is None else int(index))
    for name, given in indices.items():
        if given == [None]:
            continue
        size = len(defaults[name]) if isinstance(defaults[name], tuple) else 0
        if None in given or sorted(given) != list(range(size)):
            named = ", ".join(name if k is None else f"{name}[{k}]" for k in given)
            want = f"{name}[0] to {name}[{size - 1}], each once" if size else (
                f"{name} alone: its default is no tuple")
            raise ValueError(f"model {model!r}: search_space keys {named}: name {want}")


def draw_search(ranges: Mapping[str, SearchRange], rng: np.random.Generator
                ) -> dict[str, Any]:
    """One candidate's parameters from a checked search space (`check_search_space`):
    every range drawn once, in order; a tuple parameter's elements joined, and placed
    where its last element is drawn."""
    drawn: dict[str, Any] = {}
    for key, r in ranges.items():
        value = r.draw(rng)
        drawn[key] = value * drawn[r.times] if r.times else value
    params: dict[str, Any] = {}
    elements: dict[str, dict[int, Any]] = {}
    for key, value in drawn.items():
        name, index = _SEARCH_KEY.fullmatch(key).groups()
        params.pop(name, None)
        if index is None:
            params[name] = value
        else:
            elements.setdefault(name, {})[int(index)] = value
            params[name] = tuple(v for _, v in sorted(elements[name].items()))
    return params
