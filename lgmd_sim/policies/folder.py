"""A trained policy on disk: the model, and what it was trained to see.

A *policy folder* holds

- ``policy.npz``: the network's weights, plain arrays (NumPy's format, read with
  ``allow_pickle=False``);
- ``policy.json``: its `lgmd_sim.policies.config.PolicyConfig` (the environment and the
  observation pipeline it was trained with), the network's architecture (the
  stable-baselines3 policy and its keyword arguments), the observation-normalisation
  statistics frozen at save time (`lgmd_sim.policies.config.Normalizer`), and facts about
  its training (steps, command, versions).

Neither file can hold code, so a policy folder from anyone is safe to load: `load`
builds the network from the architecture and the environment's spaces, then fills in
the weights, and never unpickles. stable-baselines3's own model files (``policy.zip``
of folders written before this format, a training run's checkpoints) are pickles that
run whatever their author put in them: they are never loaded from a policy folder, and
``python -m lgmd_sim.policies.convert DIR`` turns a trusted one into this format.

`lgmd-sim train` writes one at the end of a run (``DIR``) and one for the best
validation score (``DIR/best``); the policies shipped with lgmd-sim
(`lgmd_sim.policies.available`) are policy folders too. `load` gives back everything
`lgmd_sim.controllers.Policy` needs to act as in training.
"""

from __future__ import annotations

import json
import os
import textwrap
import zipfile
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.extras import require
from lgmd_sim.fileio import write_files
from lgmd_sim.policies.config import Normalizer, PolicyConfig

__all__ = ["ALGOS", "MODEL_FILE", "OBS", "SB3_FILE", "LoadedPolicy", "convert", "load",
           "load_config", "name_of", "resolve", "save"]

#: The algorithms `lgmd-sim train` offers: name -> stable-baselines3 class.
ALGOS = {"ppo": "PPO", "sac": "SAC"}
#: What a policy observes: the LGMD wrapper's compact features, small grey frames, or the
#: ground truth the Oracle reads (`lgmd_sim.envs.wrappers.PrivilegedObservation`).
OBS = ("features", "pixels", "privileged")
MODEL_FILE, CONFIG_FILE = "policy.npz", "policy.json"
#: stable-baselines3's model file, in policy folders written before `MODEL_FILE`: a pickle.
SB3_FILE = "policy.zip"


@dataclass
class LoadedPolicy:
    """A policy ready to act: its folder, configuration, network (a stable-baselines3
    policy, on the CPU, in evaluation mode) and normaliser."""

    folder: Path
    config: PolicyConfig
    network: Any
    normalize: Normalizer
    facts: dict[str, Any]

    @property
    def name(self) -> str:
        return name_of(self.folder)


def name_of(folder: Path) -> str:
    """A policy's name: its folder's, or RUN-best for the best one of a training run."""
    return f"{folder.parent.name}-best" if folder.name == "best" else folder.name


def resolve(path: str | os.PathLike) -> Path:
    """The policy folder `path` names: a folder holding ``policy.json`` and ``policy.npz``,
    or the name of a shipped policy ("shipped": the default one).

    Raises:
        ValueError: no policy there, naming what was looked for; a folder with only
            stable-baselines3's pickled ``policy.zip``, saying how to convert it.
    """
    from lgmd_sim.policies import DEFAULT, available
    from lgmd_sim.policies import path as shipped

    folder = Path(path)
    if str(path) in ("shipped", *available()):
        folder = shipped(DEFAULT if str(path) == "shipped" else str(path))
    if (folder / CONFIG_FILE).is_file() and not (folder / MODEL_FILE).is_file() and (
            folder / SB3_FILE).is_file():
        raise ValueError(f"{folder / SB3_FILE} is a stable-baselines3 model file, which holds "
                         "pickles (code that runs when loaded), and policies are not loaded "
                         "from one: if it comes from someone you trust, convert it with "
                         f"python -m lgmd_sim.policies.convert {folder}")
    if not ((folder / CONFIG_FILE).is_file() and (folder / MODEL_FILE).is_file()):
        raise ValueError(f"no policy at {path}: expected a folder with {MODEL_FILE} and "
                         f"{CONFIG_FILE} (as lgmd-sim train writes), or a shipped policy: "
                         f"shipped, {', '.join(available())}")
    return folder


def load_config(path: str | os.PathLike) -> tuple[Path, PolicyConfig, dict[str, Any]]:
    """(folder, configuration, the whole policy.json) of the policy at `path`."""
    return _read_config(resolve(path))


def _read_config(folder: Path) -> tuple[Path, PolicyConfig, dict[str, Any]]:
    try:
        data = json.loads((folder / CONFIG_FILE).read_text())
        config = PolicyConfig.from_json(data["config"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{folder / CONFIG_FILE} is not a policy configuration ({exc})"
                         ) from None
    if config.algo not in ALGOS or config.obs not in OBS:
        raise ValueError(f"{folder / CONFIG_FILE}: a policy of {config.algo!r} on "
                         f"{config.obs!r}, not one of {', '.join(ALGOS)} on "
                         f"{', '.join(OBS)}")
    return folder, config, data


def load(path: str | os.PathLike) -> LoadedPolicy:
    """The policy at `path` (see `resolve`), its network on the CPU: built from
    policy.json's architecture and the spaces of the environment as the policy observes
    it (`lgmd_sim.policies.observe`), its weights from policy.npz; nothing is unpickled.

    Raises:
        ValueError: weights that are not plain arrays or do not fit the network; a
            policy.json whose network, statistics or environment this cannot rebuild (one
            line naming the file).
    """
    import gymnasium as gym

    from lgmd_sim.policies.observe import base_env, observe

    folder, config, data = load_config(path)
    sb3 = require("stable_baselines3", "rl")
    import torch

    weights = _weights(folder / MODEL_FILE)
    normalize = _normalizer(folder, data)
    network = data.get("network") or {}
    aliases = getattr(sb3, ALGOS[config.algo]).policy_aliases
    if network.get("policy") not in aliases or not isinstance(network.get("kwargs"), dict):
        raise ValueError(f"{folder / CONFIG_FILE}: its \"network\" is not a stable-baselines3 "
                         f"policy of {config.algo} ({', '.join(aliases)}) with its keyword "
                         "arguments")
    if config.env_id not in gym.registry:  # gym.make would import a "module:" prefix
        raise ValueError(f"{folder / CONFIG_FILE}: environment {config.env_id!r} is not "
                         "registered (lgmd-sim envs lists the scenarios)")
    env = observe(base_env(config), config)
    spaces = (env.observation_space, env.action_space)
    env.close()
    shapes = {k: s.shape for k, s in spaces[0].spaces.items()}
    if normalize.mean.keys() != normalize.var.keys() or any(
            shapes.get(k) != s[k].shape for s in (normalize.mean, normalize.var) for k in s):
        raise ValueError(f"{folder / CONFIG_FILE}: its \"normalize\" statistics do not fit the "
                         f"observations of {config.env_id} ({shapes})")
    try:
        policy = aliases[network["policy"]](*spaces, lambda _: 0.0, **network["kwargs"])
        policy.load_state_dict({k: torch.from_numpy(v) for k, v in weights.items()})
    except (TypeError, ValueError, RuntimeError, KeyError, AttributeError, AssertionError
            ) as exc:  # the architecture's arguments, or (torch) a missing or misshapen array
        raise ValueError(f"{folder / MODEL_FILE} does not fit the network of {CONFIG_FILE} "
                         f"in {config.env_id} as it is now ({textwrap.shorten(str(exc), 300)})"
                         ) from None
    policy.set_training_mode(False)
    return LoadedPolicy(folder, config, policy, normalize, data.get("trained", {}))


def _normalizer(folder: Path, data: Mapping[str, Any]) -> Normalizer:
    """The observation statistics of policy.json's `data`, in `folder`."""
    try:
        return Normalizer.from_json(data.get("normalize"))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ValueError(f"{folder / CONFIG_FILE}: its \"normalize\" is not observation "
                         f"statistics ({exc!r})") from None


def _weights(file: Path) -> dict[str, np.ndarray]:
    """The arrays of `file`, refusing anything else (a pickle, an object array)."""
    try:
        npz = np.load(file, allow_pickle=False)
        if not isinstance(npz, Mapping):
            raise ValueError("one bare array, not an archive of arrays")
        with npz:
            return {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        # NumPy takes anything that is not an array file for a pickle, and its message
        # suggests loading it unpickled: the one thing not to do here
        reason = ("not an array file, and never unpickled" if "allow_pickle" in str(exc)
                  else str(exc))
        raise ValueError(f"{file} is not a policy's weights, arrays as lgmd-sim train "
                         f"writes them ({reason})") from None


def save(folder: str | os.PathLike, model: Any, config: PolicyConfig,
         normalize: Normalizer, **facts: Any) -> Path:
    """Write a policy folder from a stable-baselines3 model: its policy network's weights
    and policy.json, which move into place together. `facts` go to policy.json's
    "trained" section.

    Raises:
        ValueError: a network `load` could not rebuild (a policy class of its own, or
            keyword arguments that are not JSON).
    """
    folder = Path(folder)
    aliases = {cls: name for name, cls in type(model).policy_aliases.items()}
    try:
        network = {"policy": aliases[type(model.policy)], "kwargs": json.loads(json.dumps(
            {**model.policy_kwargs, "use_sde": model.use_sde}))}
    except (KeyError, TypeError) as exc:
        raise ValueError(f"cannot save the policy in {folder}: only stable-baselines3's own "
                         f"policies with JSON keyword arguments are saved ({exc})") from None
    arrays = {k: v.detach().cpu().numpy() for k, v in model.policy.state_dict().items()}

    def write_weights(tmp: Path) -> None:
        with tmp.open("wb") as f:  # a file, not a name: savez would add ".npz" to a name
            np.savez(f, **arrays)

    text = json.dumps({"config": config.to_json(), "network": network,
                       "normalize": normalize.to_json(), "trained": facts}, indent=1)
    write_files({folder / MODEL_FILE: write_weights,
                 folder / CONFIG_FILE: lambda tmp: tmp.write_text(text)})
    return folder


def convert(folder: str | os.PathLike) -> Path:
    """Rewrite the policy folder `folder` of stable-baselines3's ``policy.zip`` (as
    written before `MODEL_FILE`) in this format: policy.npz, and policy.json with the
    network. The zip is unpickled: convert only one you made or that comes from someone
    you trust. It stays in place, and nothing loads it any more.

    Raises:
        ValueError: a folder without both files; a policy.json or policy.zip this cannot
            read (one line naming the file).
    """
    folder = Path(folder)
    if not ((folder / SB3_FILE).is_file() and (folder / CONFIG_FILE).is_file()):
        raise ValueError(f"no policy to convert in {folder}: expected {SB3_FILE} and "
                         f"{CONFIG_FILE}")
    _, config, data = _read_config(folder)
    normalize = _normalizer(folder, data)
    algo = getattr(require("stable_baselines3", "rl"), ALGOS[config.algo])
    # Schedules are pickled functions, needless to act and fragile across versions.
    custom = {"learning_rate": 0.0, "lr_schedule": lambda _: 0.0, "clip_range": lambda _: 0.0}
    try:
        model = algo.load(folder / SB3_FILE, device="cpu", custom_objects=custom)
    except Exception as exc:  # unpickling fails in whatever way the bytes lead it to
        raise ValueError(f"{folder / SB3_FILE}: not a {ALGOS[config.algo]} model file "
                         "stable-baselines3 can load ("
                         f"{textwrap.shorten(f'{type(exc).__name__}: {exc}', 300)})") from None
    return save(folder, model, config, normalize, **data.get("trained", {}))
