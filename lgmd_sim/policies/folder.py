"""A trained policy on disk: the model, and what it was trained to see.

A *policy folder* holds

- ``policy.zip``: the stable-baselines3 model;
- ``policy.json``: its `PolicyConfig` (the environment and the observation pipeline it
  was trained with), the observation-normalisation statistics frozen at save time, and
  facts about its training (steps, command, versions).

`lgmd-sim train` writes one at the end of a run (``DIR``) and one for the best
validation score (``DIR/best``); the policies shipped with lgmd-sim
(`lgmd_sim.policies.available`) are policy folders too. `load` gives back everything
`lgmd_sim.controllers.Policy` needs to act as in training.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.extras import require
from lgmd_sim.fileio import write_files, write_text_atomic

__all__ = ["ALGOS", "OBS", "LoadedPolicy", "Normalizer", "PolicyConfig", "load", "load_config",
           "name_of", "resolve", "save"]

#: The algorithms `lgmd-sim train` offers: name -> stable-baselines3 class.
ALGOS = {"ppo": "PPO", "sac": "SAC"}
#: What a policy observes: the LGMD wrapper's compact features, or small grey frames.
OBS = ("features", "pixels")
MODEL_FILE, CONFIG_FILE = "policy.zip", "policy.json"


@dataclass(frozen=True)
class PolicyConfig:
    """The environment a policy was trained in and the observation pipeline it sees.

    Attributes:
        algo: a key of `ALGOS`.
        obs: "features" (an LGMD model's potentials, alarm and S-layer grid with the
            proprioception and goal; an MLP policy) or "pixels" (the last `frame_stack`
            grey frames at `frame_size` with the proprioception and goal; a CNN policy).
        env_id: the Gymnasium id of the environment.
        resolution: the frame size the environment renders (a preset name or [H, W]).
        jitter: the jitter level it was trained at.
        model, preset: the LGMD model and its preset (features).
        history, grid: the potentials observed and the S-layer grid (features).
        frame_size, frame_stack: the observed frames (pixels).
    """

    algo: str
    obs: str
    env_id: str
    resolution: str | tuple[int, int] = "rl"
    jitter: float = 1.0
    model: str | None = None
    preset: str | None = None
    history: int = 8
    grid: tuple[int, int] = (1, 3)
    frame_size: tuple[int, int] = (60, 80)
    frame_stack: int = 4

    def to_json(self) -> dict[str, Any]:
        return json.loads(json.dumps(asdict(self)))

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> PolicyConfig:
        def pair(v: Any) -> Any:
            return tuple(v) if isinstance(v, list) else v

        return cls(**{k: pair(v) for k, v in data.items()})


@dataclass(frozen=True)
class Normalizer:
    """Observation normalisation as stable-baselines3's ``VecNormalize`` does it, with its
    statistics frozen: ``clip((obs - mean) / sqrt(var + epsilon), -clip, clip)`` per key,
    as float32; keys without statistics pass unchanged. Empty: the identity."""

    mean: Mapping[str, np.ndarray] = field(default_factory=dict)
    var: Mapping[str, np.ndarray] = field(default_factory=dict)
    clip: float = 10.0
    epsilon: float = 1e-8

    @classmethod
    def of(cls, vec_normalize: Any | None) -> Normalizer:
        """The statistics of a ``VecNormalize`` (None: no normalisation)."""
        if vec_normalize is None or not vec_normalize.norm_obs:
            return cls()
        rms = vec_normalize.obs_rms
        return cls({k: rms[k].mean.copy() for k in vec_normalize.norm_obs_keys},
                   {k: rms[k].var.copy() for k in vec_normalize.norm_obs_keys},
                   float(vec_normalize.clip_obs), float(vec_normalize.epsilon))

    def __call__(self, obs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        out = dict(obs)
        for k in self.mean:
            z = (obs[k] - self.mean[k]) / np.sqrt(self.var[k] + self.epsilon)
            out[k] = np.clip(z, -self.clip, self.clip).astype(np.float32)
        return out

    def to_json(self) -> dict[str, Any] | None:
        if not self.mean:
            return None
        return {"clip": self.clip, "epsilon": self.epsilon,
                "mean": {k: v.tolist() for k, v in self.mean.items()},
                "var": {k: v.tolist() for k, v in self.var.items()}}

    @classmethod
    def from_json(cls, data: Mapping[str, Any] | None) -> Normalizer:
        if not data:
            return cls()
        return cls({k: np.array(v) for k, v in data["mean"].items()},
                   {k: np.array(v) for k, v in data["var"].items()},
                   float(data["clip"]), float(data["epsilon"]))


@dataclass
class LoadedPolicy:
    """A policy ready to act: its folder, configuration, model and normaliser."""

    folder: Path
    config: PolicyConfig
    model: Any
    normalize: Normalizer
    facts: dict[str, Any]

    @property
    def name(self) -> str:
        return name_of(self.folder)


def name_of(folder: Path) -> str:
    """A policy's name: its folder's, or RUN-best for the best one of a training run."""
    return f"{folder.parent.name}-best" if folder.name == "best" else folder.name


def resolve(path: str | os.PathLike) -> Path:
    """The policy folder `path` names: a folder holding ``policy.json`` and ``policy.zip``,
    or the name of a shipped policy ("shipped": the default one).

    Raises:
        ValueError: no policy there, naming what was looked for.
    """
    from lgmd_sim.policies import DEFAULT, available
    from lgmd_sim.policies import path as shipped

    folder = Path(path)
    if str(path) in ("shipped", *available()):
        folder = shipped(DEFAULT if str(path) == "shipped" else str(path))
    if not ((folder / CONFIG_FILE).is_file() and (folder / MODEL_FILE).is_file()):
        raise ValueError(f"no policy at {path}: expected a folder with {MODEL_FILE} and "
                         f"{CONFIG_FILE} (as lgmd-sim train writes), or a shipped policy: "
                         f"shipped, {', '.join(available())}")
    return folder


def load_config(path: str | os.PathLike) -> tuple[Path, PolicyConfig, dict[str, Any]]:
    """(folder, configuration, the whole policy.json) of the policy at `path`."""
    folder = resolve(path)
    try:
        data = json.loads((folder / CONFIG_FILE).read_text())
        config = PolicyConfig.from_json(data["config"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{folder / CONFIG_FILE} is not a policy configuration ({exc})"
                         ) from None
    return folder, config, data


def load(path: str | os.PathLike) -> LoadedPolicy:
    """The policy at `path` (see `resolve`), its model on the CPU."""
    folder, config, data = load_config(path)
    sb3 = require("stable_baselines3", "rl")
    algo = getattr(sb3, ALGOS[config.algo])
    # Schedules are pickled functions, needless to act and fragile across versions.
    custom = {"learning_rate": 0.0, "lr_schedule": lambda _: 0.0, "clip_range": lambda _: 0.0}
    model = algo.load(folder / MODEL_FILE, device="cpu", custom_objects=custom)
    return LoadedPolicy(folder, config, model, Normalizer.from_json(data.get("normalize")),
                        data.get("trained", {}))


def save(folder: str | os.PathLike, model: Any, config: PolicyConfig,
         normalize: Normalizer, **facts: Any) -> Path:
    """Write a policy folder: the model, then policy.json (the folder is a policy once
    policy.json is there). `facts` go to policy.json's "trained" section."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_files({folder / MODEL_FILE: model.save})  # the temporary file ends in .zip too
    write_text_atomic(folder / CONFIG_FILE, json.dumps(
        {"config": config.to_json(), "normalize": normalize.to_json(), "trained": facts},
        indent=1))
    return folder
