"""Named, checked values: the one validation mechanism of the package.

A check (`Check`) returns what is wrong with a value, or None. `checked` holds a named
value to one and raises `FieldError`, a ValueError that names the field; the command line
names the option that set it instead (`lgmd_sim.cli`), and its argument types are the same
checks (`lgmd_sim.cli.args.argtype`).

A parameter set (models, world, envs, controllers) is a frozen dataclass deriving from
`CheckedParams`; each field is made with `param(default, source, check=..., doc=...)`, so
that every number carries where its default comes from, and every value is checked when
the set is created.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

Check = Callable[[Any], str | None]  # returns an error message, or None when valid


class FieldError(ValueError):
    """A value a named field may not hold, in one line that names the field.

    Attributes:
        field: the field's name ("seeds", "goal.jitter"): a command line maps it to the
            option that set it.
        problem: the line without the field's name ("must be an integer >= 1, got 0").

    Args:
        text: the line, where it says more than the field and the problem.
    """

    def __init__(self, field: str, problem: str, *, text: str | None = None) -> None:
        super().__init__(text or f"{field} {problem}")
        self.field = field
        self.problem = problem


def checked(field: str, value: Any, check: Check) -> Any:
    """`value` if `check` accepts it, else a `FieldError` naming `field`."""
    error = check(value)
    if error:
        raise FieldError(field, f"{error}, got {value!r}")
    return value


def comma_list(text: str) -> list[str]:
    """The items of a comma-separated list, stripped, empty ones dropped (a parameter or an
    option that lists names, as text)."""
    return [t.strip() for t in text.split(",") if t.strip()]


def param(default: Any, source: str, *, check: Check | None = None, doc: str = "") -> Any:
    """A parameter: its default, where that default comes from, and its check."""
    return dataclasses.field(
        default=default, metadata={"source": source, "check": check, "doc": doc}
    )


def _is_real(v: Any) -> bool:
    return (isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)
            and bool(np.isfinite(v)))


def positive(v: Any) -> str | None:
    return None if _is_real(v) and v > 0 else "must be a finite number > 0"


def non_negative(v: Any) -> str | None:
    return None if _is_real(v) and v >= 0 else "must be a finite number >= 0"


def finite(v: Any) -> str | None:
    return None if _is_real(v) else "must be a finite number"


def because(check: Check, reason: str) -> Check:
    """`check`, its message followed by `reason`: why a value that is a number is still
    refused (one that would make the output constant, say)."""

    def explained(v: Any) -> str | None:
        error = check(v)
        return None if error is None else f"{error} ({reason})"

    return explained


def in_range(lo: float, hi: float) -> Check:
    def check(v: Any) -> str | None:
        return None if _is_real(v) and lo <= v <= hi else f"must be a number in [{lo}, {hi}]"

    return check


def int_at_least(lo: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= lo
        return None if ok else f"must be an integer >= {lo}"

    return check


def int_in_range(lo: int, hi: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int | np.integer) and not isinstance(v, bool) and lo <= v <= hi
        return None if ok else f"must be an integer in [{lo}, {hi}]"

    return check


def text(v: Any) -> str | None:
    return None if isinstance(v, str) else "must be a string"


#: How many of a thing (episodes, seeds, steps): an integer >= 1.
count = int_at_least(1)
#: A seed, or a first seed: an integer >= 0.
seed = int_at_least(0)


def one_of(*choices: Any) -> Check:
    def check(v: Any) -> str | None:
        return None if v in choices else f"must be one of {', '.join(map(repr, choices))}"

    return check


def tuple_of(check: Check, length: int | None = None, *, min_length: int = 0,
             max_length: int | None = None) -> Check:
    """Check every element of a sequence parameter, and its length (exactly `length`, or
    between `min_length` and `max_length`)."""
    lo, hi = (length, length) if length is not None else (min_length, max_length)

    count = (f"{lo} " if lo == hi else f"{lo} to {hi} " if hi is not None
             else f"{lo} or more " if lo else "")

    def check_all(v: Any) -> str | None:
        if not isinstance(v, tuple | list) or len(v) < lo or (hi is not None and len(v) > hi):
            return f"must be a sequence of {count}values"
        errors = [e for e in map(check, v) if e]
        if not errors:
            return None
        each = errors[0].removeprefix("must be ")  # "an integer >= 1", "one of 'a', 'b'"
        return f"must be a sequence of {count}values, each {each}"

    return check_all


def optional(check: Check) -> Check:
    """Accept None (meaning: derived from other parameters) or what `check` accepts."""

    def check_optional(v: Any) -> str | None:
        return None if v is None else check(v)

    return check_optional


@dataclass(frozen=True)
class CheckedParams:
    """A frozen parameter set whose fields are checked on creation."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, list):  # TOML and JSON give lists; keep the set hashable
                value = tuple(value)
                object.__setattr__(self, f.name, value)
            check = f.metadata.get("check")
            error = check(value) if check else None
            if error:
                raise FieldError(f.name, f"{error}, got {value!r}", text=(
                    f"{type(self).__name__}: parameter {f.name}={value!r} {error}"))

    @classmethod
    def describe(cls) -> list[tuple[str, Any, str, str]]:
        """(name, default, source, doc) for every parameter, for docs and listings."""
        return [
            (f.name, f.default, f.metadata.get("source", ""), f.metadata.get("doc", ""))
            for f in dataclasses.fields(cls)
        ]

    @classmethod
    def names(cls) -> set[str]:
        return {f.name for f in dataclasses.fields(cls)}

    def replace(self, **changes: Any) -> CheckedParams:
        """A copy with some parameters changed; unknown names are an error."""
        unknown = sorted(set(changes) - self.names())
        if unknown:
            raise ValueError(f"unknown parameter(s) {', '.join(unknown)}; "
                             f"known: {', '.join(sorted(self.names()))}")
        return dataclasses.replace(self, **changes)
