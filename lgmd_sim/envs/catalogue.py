"""The scenario catalogue: one TOML file per scenario, each registered with Gymnasium.

A scenario file holds a one-line ``description`` and a ``[params]`` table of overrides of
`EnvParams` defaults. Each is registered as ``lgmd_sim/<Name>-v0`` (Name is the file's
stem); ``gym.make(id, **overrides)`` overrides again. The packaged scenarios (envs/) load
when lgmd_sim is imported, then the folders listed in the ``LGMD_SIM_ENVS`` environment
variable (separated by ``os.pathsep``); `register_catalogue` adds a folder later.

A file that cannot be used (unreadable, larger than `lgmd_sim.core.fileio.TEXT_LIMIT`, not
UTF-8, invalid TOML, unknown keys, a name that is no valid environment id, a name already
taken) breaks only itself: ``lgmd-sim envs`` reports it in one line, ``gym.make`` of its id
raises that line as a ValueError, and every other scenario works. This module imports
neither MuJoCo nor the environment: registration uses entry-point strings.
"""

from __future__ import annotations

import os
import re
import tomllib
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from lgmd_sim.core.fileio import read_text
from lgmd_sim.core.resources import envs_dir

NAMESPACE = "lgmd_sim"
ENTRY_POINT = "lgmd_sim.envs.jitter_env:JitterEnv"
#: Folders of user scenarios read at import, separated by os.pathsep.
ENV_VAR = "LGMD_SIM_ENVS"
#: A scenario name must make a valid Gymnasium id (lgmd_sim/<Name>-v0).
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_KEYS = frozenset({"description", "params"})


@dataclass(frozen=True)
class Scenario:
    """One scenario file: its overrides, or the reason it cannot be used (``error``)."""

    name: str
    path: Path
    description: str = ""
    overrides: Mapping[str, Any] = field(default_factory=dict)
    error: str | None = None

    @property
    def env_id(self) -> str:
        return f"{NAMESPACE}/{self.name}-v0"


_catalogue: dict[str, Scenario] = {}  # name -> scenario, broken ones included
_unnamed: list[str] = []  # files that could not be registered at all, as error lines
_folders: list[Path] = []


def _read(path: Path) -> Scenario:
    def broken(problem: str) -> Scenario:
        return Scenario(path.stem, path, error=f"scenario file {path}: {problem}")

    try:
        data = tomllib.loads(read_text(path))
    except tomllib.TOMLDecodeError as exc:
        return broken(f"invalid TOML: {exc}")
    except ValueError as exc:  # unreadable, too large, not text: read_text names the file
        return Scenario(path.stem, path, error=f"scenario file {exc}")
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        return broken(f"unknown top-level key(s) {', '.join(unknown)}; a scenario file has "
                      "a 'description' and a [params] table")
    if not isinstance(data.get("description", ""), str):
        return broken("'description' must be a string")
    params = data.get("params", {})
    if not isinstance(params, dict):
        return broken(f"'params' must be a table ([params]), got {type(params).__name__}")
    return Scenario(path.stem, path, data.get("description", "").strip(), params)


def _load_folder(folder: Path) -> tuple[list[str], list[str]]:
    """Read and register every scenario file of a folder: (usable names, problems)."""
    import gymnasium

    names, problems = [], []
    for path in sorted(folder.glob("*.toml")):
        other = _catalogue.get(path.stem)
        if not _NAME.fullmatch(path.stem):
            problems.append(f"scenario file {path}: its name {path.stem!r} is not a valid "
                            "environment name (letters, digits and _, starting with a "
                            "letter); rename the file")
            _unnamed.append(problems[-1])
            continue
        if other is not None:
            problems.append(f"scenario file {path}: scenario {path.stem} is already defined "
                            f"by {other.path}; rename the file")
            _unnamed.append(problems[-1])
            continue
        sc = _read(path)
        _catalogue[sc.name] = sc
        if sc.error:
            problems.append(sc.error)
        else:
            names.append(sc.name)
        # Broken ones too: gym.make of their id then says what is wrong with the file.
        # Episodes end by the env's own time limit (time_limit * fps steps), so that a
        # time_limit override holds; no TimeLimit wrapper is added here.
        gymnasium.register(id=sc.env_id, entry_point=ENTRY_POINT, kwargs={"scenario": sc.name})
    _folders.append(folder)
    return names, problems


def register_all() -> None:
    """Load and register the packaged scenarios and those of ``LGMD_SIM_ENVS`` (once)."""
    if _folders:
        return
    _load_folder(envs_dir())
    for folder in filter(None, os.environ.get(ENV_VAR, "").split(os.pathsep)):
        if Path(folder).is_dir():
            _load_folder(Path(folder))
        else:
            _unnamed.append(f"{ENV_VAR}: no such folder {folder}")


def register_catalogue(folder: str | os.PathLike) -> list[str]:
    """Register the scenario files of a folder of your own; return the usable names.

    A file that cannot be used is reported with a warning (and by ``lgmd-sim envs`` and
    `catalogue_errors`); ``gym.make`` of its id raises the same message. The folder is
    also added to ``LGMD_SIM_ENVS`` of this process, so that worker processes started
    from it (vector environments) know the scenarios too.
    """
    register_all()
    path = Path(folder).expanduser().resolve()
    if not path.is_dir():
        raise ValueError(f"cannot register scenarios from {folder}: no such folder")
    if path in _folders:
        return [sc.name for sc in _catalogue.values() if sc.path.parent == path and not sc.error]
    names, problems = _load_folder(path)
    for problem in problems:
        warnings.warn(problem, stacklevel=2)
    os.environ[ENV_VAR] = os.pathsep.join(filter(None, [os.environ.get(ENV_VAR), str(path)]))
    return names


def scenarios() -> dict[str, Scenario]:
    """Every usable scenario, by name: the packaged ones in name order, then the users'."""
    register_all()
    return {n: sc for n, sc in _catalogue.items() if sc.error is None}


def catalogue_errors() -> list[str]:
    """One line per scenario file that cannot be used, naming the file and the problem."""
    register_all()
    return [sc.error for sc in _catalogue.values() if sc.error] + _unnamed


def scenario(name: str) -> Scenario:
    """The scenario `name` (e.g. "RoughTerrainObstacles"); a broken one raises its error."""
    register_all()
    sc = _catalogue.get(name)
    if sc is None:
        raise ValueError(f"unknown scenario {name!r}; available: {', '.join(scenarios())}")
    if sc.error:
        raise ValueError(sc.error)
    return sc


def params_for(name: str | None, overrides: Mapping[str, Any]):  # -> EnvParams
    """The checked parameters of scenario `name` (None: the defaults) with overrides."""
    from lgmd_sim.envs.params import EnvParams

    sc = scenario(name) if name is not None else None
    base = sc.overrides if sc is not None else {}
    names = EnvParams.names()
    for source, values in (("scenario file", base), ("override", overrides)):
        unknown = sorted(set(values) - names)
        if unknown:
            where = "" if sc is None else f" {sc.path}" if source == "scenario file" else (
                f" of {sc.name}")
            raise ValueError(f"unknown parameter(s) {', '.join(unknown)} ({source}{where}); "
                             f"known: {', '.join(sorted(names))}")
    try:
        return EnvParams(**{**base, **overrides})
    except ValueError:
        if sc is not None:  # the file's own values at fault? then name the file
            try:
                EnvParams(**base)
            except ValueError as exc:
                raise ValueError(f"scenario file {sc.path}: {exc}") from None
        raise
