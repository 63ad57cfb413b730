"""The scenario catalogue: envs/*.toml, one scenario per file, registered with Gymnasium.

A scenario file holds a one-line ``description`` and a ``[params]`` table of overrides of
`EnvParams` defaults. Each is registered as ``lgmd_sim/<Name>-v0`` (Name is the file's
stem) when lgmd_sim is imported; ``gym.make(id, **overrides)`` overrides again. This
module imports neither MuJoCo nor the environment: registration uses entry-point strings.
"""

from __future__ import annotations

import argparse
import functools
import tomllib
from dataclasses import dataclass
from typing import Any

from lgmd_sim.resources import envs_dir

NAMESPACE = "lgmd_sim"
ENTRY_POINT = "lgmd_sim.envs.jitter_env:JitterEnv"


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    overrides: dict[str, Any]

    @property
    def env_id(self) -> str:
        return f"{NAMESPACE}/{self.name}-v0"


@functools.cache
def scenarios() -> dict[str, Scenario]:
    """Every scenario of the catalogue, by name, in name order."""
    found: dict[str, Scenario] = {}
    for path in sorted(envs_dir().glob("*.toml")):
        try:
            data = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"scenario file {path}: {exc}") from exc
        unknown = set(data) - {"description", "params"}
        if unknown:
            raise ValueError(f"scenario file {path}: unknown keys {', '.join(sorted(unknown))}")
        found[path.stem] = Scenario(path.stem, str(data.get("description", "")).strip(),
                                    dict(data.get("params", {})))
    return found


def scenario(name: str) -> Scenario:
    """The scenario `name` (e.g. "RoughTerrainObstacles")."""
    known = scenarios()
    if name not in known:
        raise ValueError(f"unknown scenario {name!r}; available: {', '.join(known)}")
    return known[name]


def register_all() -> None:
    """Register every scenario as lgmd_sim/<Name>-v0 (once; cheap, imports no MuJoCo)."""
    import gymnasium

    for sc in scenarios().values():
        if sc.env_id not in gymnasium.registry:
            # Episodes end by the env's own time limit (time_limit * fps steps), so that
            # a time_limit override holds; no TimeLimit wrapper is added here.
            gymnasium.register(id=sc.env_id, entry_point=ENTRY_POINT,
                               kwargs={"scenario": sc.name})


def params_for(name: str | None, overrides: dict[str, Any]):  # -> EnvParams
    """The checked parameters of scenario `name` (None: the defaults) with overrides."""
    from lgmd_sim.envs.params import EnvParams

    base = scenario(name).overrides if name is not None else {}
    names = EnvParams.names()
    for source, values in (("scenario file", base), ("override", overrides)):
        unknown = sorted(set(values) - names)
        if unknown:
            raise ValueError(f"unknown parameter(s) {', '.join(unknown)} ({source}"
                             f"{'' if name is None else ' of ' + name}); "
                             f"known: {', '.join(sorted(names))}")
    return EnvParams(**{**base, **overrides})


def run_list(args: argparse.Namespace) -> int:
    """`lgmd-sim envs [name]`: the scenarios with their parameters."""
    from lgmd_sim.envs.params import EnvParams

    names = [scenario(args.name).name] if getattr(args, "name", None) else list(scenarios())
    defaults = {n: d for n, d, _s, _doc in EnvParams.describe()}
    for name in names:
        sc = scenario(name)
        params = params_for(name, {})
        print(f"{sc.env_id}: {sc.description}")
        if args.name:  # one scenario: every parameter, its value, doc and source
            for pname, _default, source, doc in EnvParams.describe():
                mark = "*" if pname in sc.overrides else " "
                print(f" {mark}{pname} = {getattr(params, pname)!r}  # {doc} [{source}]")
            print("  (* set by the scenario; override any with gym.make(id, name=value))")
        else:
            for pname in sc.overrides:
                print(f"    {pname} = {getattr(params, pname)!r}"
                      f"  (default {defaults[pname]!r})")
        print()
    return 0
