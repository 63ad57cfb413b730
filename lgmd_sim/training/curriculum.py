"""A curriculum for `lgmd-sim train` (the ``curriculum`` key of its --config file): easier
versions of the task first, each stage left once the policy succeeds often enough in its
training episodes.

A goal 8 m away behind six obstacles is never reached by chance, so a policy that starts
there never sees the reward of arriving. A curriculum's stages change the environment
(fewer obstacles, less jitter, a nearer goal: a parameter of
`lgmd_sim.envs.params.EnvParams`, but neither what the policy observes or what its actions
mean, nor the reward, which the ``reward`` key sets for every stage), and after the last
one the policy trains on the task as the environment defines it until the step budget is
spent. Validation always runs on that task, so the learning curve and the best policy are
the real task's.

A stage is left when the success rate of its last ``window`` training episodes reaches
its ``advance_at``. The training environments are then built anew with the next stage's
parameters (the observation spaces do not change, so the model and its normalisation carry
over) and fresh seeds (`lgmd_sim.training.callbacks.StageCallback` counts the successes).

A curriculum is a built-in name (`CURRICULA`) or a TOML file::

    window = 50            # training episodes a stage's success rate is taken over

    [[stage]]
    n_obstacles = 0
    goal_distance = 4.0
    advance_at = 0.8       # leave the stage at this success rate

    [[stage]]
    n_obstacles = 3
    advance_at = 0.7
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from lgmd_sim.core.fileio import read_text
from lgmd_sim.core.params import finite, int_at_least

__all__ = ["CURRICULA", "Curriculum", "Stage", "load"]

#: Parameters a stage may not change: what the policy observes (the frames, their rate,
#: the camera) and what its actions mean (the carrier and its speed limits).
_FIXED = ("frame", "resolution", "fps", "carrier", "camera_height", "fovy", "max_speed",
          "max_turn")


@dataclass(frozen=True)
class Stage:
    """One stage: environment parameters over the task's, and the training success rate
    (over the curriculum's window) at which the policy moves on."""

    overrides: Mapping[str, Any]
    advance_at: float

    def as_json(self) -> dict[str, Any]:
        return {**self.overrides, "advance_at": self.advance_at}


@dataclass(frozen=True)
class Curriculum:
    """Stages before the task itself, and the episodes a success rate is taken over."""

    stages: tuple[Stage, ...]
    window: int = 50
    name: str = field(default="", compare=False)

    def as_json(self) -> dict[str, Any]:
        return {"window": self.window, "stage": [s.as_json() for s in self.stages]}


#: Built-in curricula, for RoughTerrainObstacles and the tasks like it: the goal nearer and
#: the obstacles fewer at first, then the task (six obstacles, the goal 8 m away).
CURRICULA: dict[str, dict[str, Any]] = {
    "obstacles": {"window": 50, "stage": [
        {"n_obstacles": 0, "goal_distance": 4.0, "jitter": 0.5, "advance_at": 0.8},
        {"n_obstacles": 2, "goal_distance": 6.0, "advance_at": 0.7},
        {"n_obstacles": 4, "goal_distance": 8.0, "advance_at": 0.6},
    ]},
}


def load(spec: str, env_id: str) -> Curriculum:
    """The curriculum `spec` (a `CURRICULA` name or a TOML file) for environment `env_id`,
    every stage checked by building its parameters (no world is compiled).

    Raises:
        ValueError: not a string; an unknown name; a file that cannot be read, is larger than
            `lgmd_sim.core.fileio.TEXT_LIMIT` or is not TOML; a stage that is not a table, or
            whose parameters the environment refuses (one line naming the file and the
            stage).
    """
    if not isinstance(spec, str):  # open() would take a number for a file descriptor
        raise ValueError(f"curriculum must be a curriculum's name or a TOML file's path, "
                         f"got {spec!r}")
    if spec in CURRICULA:
        data = CURRICULA[spec]
    else:
        try:
            data = tomllib.loads(read_text(spec))
        except ValueError as exc:  # read_text's refusals and TOML's
            # read_text's name the file, which this line names once
            raise ValueError(f"curriculum {spec}: not a built-in curriculum "
                             f"({', '.join(CURRICULA)}) nor a readable TOML file "
                             f"({str(exc).removeprefix(f'{spec}: ')})") from None
    return _parse(data, env_id, spec)


def _parse(data: Mapping[str, Any], env_id: str, name: str) -> Curriculum:
    import gymnasium as gym

    from lgmd_sim.envs.catalogue import params_for
    from lgmd_sim.training.envs import REWARD_KEYS

    unknown = sorted(set(data) - {"window", "stage"})
    window = data.get("window", 50)
    raw = data.get("stage", [])
    # the parameters' checks: TOML's true and false are no numbers, though Python's are
    if unknown or int_at_least(1)(window) or not isinstance(raw, list) or not raw:
        raise ValueError(f"curriculum {name}: needs a positive integer `window` and one "
                         "or more [[stage]] tables" + (f", not {', '.join(unknown)}"
                                                       if unknown else ""))
    scenario = gym.spec(env_id).kwargs.get("scenario")
    stages = []
    for i, table in enumerate(raw, 1):
        where = f"curriculum {name}: stage {i}"
        if not isinstance(table, dict):
            raise ValueError(f"{where} is {type(table).__name__}, not a table of parameters "
                             "([[stage]])")
        overrides = {k: v for k, v in table.items() if k != "advance_at"}
        at = table.get("advance_at")
        if finite(at) or not 0.0 < at <= 1.0:
            raise ValueError(f"{where}: advance_at must be a success rate in (0, 1], got {at!r}")
        if fixed := sorted(set(overrides) & set(_FIXED)):
            raise ValueError(f"{where}: {', '.join(fixed)} cannot change between stages (what "
                             "the policy observes or what its actions mean)")
        if reward := sorted(set(overrides) & set(REWARD_KEYS)):
            raise ValueError(f"{where}: {', '.join(reward)} is the reward's: set it for every "
                             "stage with the reward key")
        try:
            params_for(scenario, overrides)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        stages.append(Stage(overrides, float(at)))
    return Curriculum(tuple(stages), window, name)

