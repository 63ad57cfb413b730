"""A job's settings as a TOML file (``--config FILE.toml``), read, written and listed from
the job's typed configuration.

A configuration is a frozen dataclass whose fields are its settings; each field that a
file may set is declared once with `setting(default, doc)`, so that its default and its
meaning live in one place: the command line's options and help, the file's keys
(`read_toml`), the file a run's record gives back (`config_toml`) and the docs' list of
keys (`keys_markdown`) all come from it.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["config_toml", "defaults", "doc", "keys_markdown", "read_toml", "setting"]


def setting(default: Any, doc: str, *, in_file: bool = True) -> Any:
    """A field of a job's configuration: its default, and what it means (one line of the
    docs' list of keys; the option's help where the command line sets it); `in_file`:
    whether a --config file may set it (False: a value no TOML holds)."""
    metadata = {"doc": doc, "in_file": in_file}
    if isinstance(default, dict):  # mutable: each configuration its own copy
        return dataclasses.field(default_factory=lambda: dict(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def _default(f: dataclasses.Field) -> Any:
    return f.default_factory() if f.default is dataclasses.MISSING else f.default


def _keys(cls: type) -> list[dataclasses.Field]:
    """The fields of `cls` a --config file may set: its settings (`setting`) in a file."""
    return [f for f in dataclasses.fields(cls) if f.metadata.get("in_file")]


def doc(cls: type, name: str) -> str:
    """What field `name` of configuration `cls` means, as `setting` declared it."""
    return next(f.metadata["doc"] for f in dataclasses.fields(cls) if f.name == name)


def defaults(cls: type) -> dict[str, Any]:
    """The defaults of the keys of `cls`'s --config file, as JSON records them (tuples as
    lists)."""
    return {f.name: json.loads(json.dumps(_default(f))) for f in _keys(cls)}


def _toml(value: Any) -> str:
    """`value` as TOML writes it (a string, a number, a boolean, an array of them)."""
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if not isinstance(value, str | int | float):
        raise ValueError(f"{value!r} is not a value of a configuration file's key")
    return json.dumps(value)  # JSON's strings and numbers are TOML's too


def keys_markdown(cls: type) -> str:
    """The keys of `cls`'s ``--config`` file as a Markdown list, each with its default
    (where it has one) and meaning."""
    lines = []
    for f in _keys(cls):
        default = "" if _default(f) is None else f" = {_toml(_default(f))}"
        lines.append(f"- `{f.name}{default}`: {f.metadata['doc']}")
    return "\n".join(lines) + "\n"


def config_toml(cls: type, config: Mapping[str, Any]) -> str:
    """The ``--config`` file of a recorded configuration of `cls` (as JSON records it): the
    keys whose values are not the defaults, one a line. A key recorded as null is left out
    (TOML has no null): its default is null, or the configuration sets it so."""
    known = defaults(cls)
    if unknown := sorted(set(config) - set(known)):
        raise ValueError(f"{', '.join(unknown)}: not {cls.__name__}'s keys (another "
                         "lgmd-sim's record?)")
    return "".join(f"{key} = {_toml(value)}\n" for key, value in config.items()
                   if value is not None and json.loads(json.dumps(value)) != known[key])


def read_toml(path: str | Path, cls: type, listed: str = "") -> dict[str, Any]:
    """The keys of the ``--config`` file `path`: fields of `cls`, unchecked (making the
    configuration checks their values).

    Args:
        listed: what the keys are, for the message of an unknown one (None: their
            names).

    Raises:
        ValueError: a file that cannot be read or is not TOML, a key that is not one of
            them (one line naming the file, and the key).
    """
    from lgmd_sim.core.fileio import read_text

    try:
        data = tomllib.loads(read_text(path))  # read_text's refusals name the file
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not a TOML file ({exc})") from None
    allowed = list(defaults(cls))
    for key in data:
        if key not in allowed:
            near = difflib.get_close_matches(key, allowed, 1)
            raise ValueError(f"{path}: unknown key {key!r}"
                             + (f" (did you mean {near[0]}?)" if near else "")
                             + f"; the keys are {listed or ', '.join(allowed)}")
    return data
