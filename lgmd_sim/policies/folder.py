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
the weights, and never unpickles. Nor does it import anything a policy.json names: its
model is a built-in, registered or installed one, or a plug-in spec that the user names
(``lgmd-sim bench closed-loop --policies ... --models``, ``load(path, plugins=...)``), and
its environment a scenario of lgmd-sim's catalogue. stable-baselines3's own model files
(``policy.zip`` of folders written before this format, a training run's checkpoints) are
pickles that run whatever their author put in them: they are never loaded from a policy
folder, and ``python -m lgmd_sim.policies.convert DIR`` turns a trusted one into this
format.

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
from collections.abc import Collection, Mapping
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.lib import format as npy

from lgmd_sim.core.extras import require
from lgmd_sim.core.fileio import read_json, write_files
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


def load_config(path: str | os.PathLike, plugins: Collection[str] = ()
                ) -> tuple[Path, PolicyConfig, dict[str, Any]]:
    """(folder, configuration, the whole policy.json) of the policy at `path` (see
    `resolve`), its names checked before anything they name is imported or made.

    Args:
        path: a policy folder or a shipped policy's name.
        plugins: plug-in model specs ("package.module:Class") the user names, which the
            policy may observe besides the built-in, registered and installed models.

    Raises:
        ValueError: no policy there; a policy.json that is not a policy's configuration,
            whose model is none of those (importing a spec runs its module: a policy from
            anyone must not choose code to run), whose preset is not a name, or whose
            environment is not a scenario of lgmd-sim (one line naming the file and key).
    """
    folder, config, data = _read_config(resolve(path))
    _check_names(folder / CONFIG_FILE, config, plugins)
    return folder, config, data


def _check_names(file: Path, config: PolicyConfig, plugins: Collection[str]) -> None:
    """Refuse a `config` (of policy.json `file`) naming a model, preset or environment
    that is not one the user chose or lgmd-sim ships (see `load_config`)."""
    from lgmd_sim import models
    from lgmd_sim.envs.catalogue import scenarios

    model = config.model
    if model is not None and not (isinstance(model, str) and (
            model in plugins or models.origin(model) != "spec")):
        raise ValueError(f"{file}: config.model {_shown(model)} is not a built-in, registered "
                         "or installed model (lgmd-sim models lists them); a plug-in's spec "
                         "is imported, running its code, so a policy may name one only if "
                         "you name it too (lgmd-sim bench closed-loop --models SPEC, or "
                         "policies.load(path, plugins=[SPEC]))")
    if config.preset is not None and not isinstance(config.preset, str):
        raise ValueError(f"{file}: config.preset {_shown(config.preset)} is not a preset's "
                         "name")
    if not (isinstance(config.env_id, str) and config.env_id in {
            sc.env_id for sc in scenarios().values()}):
        # gym.make would import the module of a "module:Env" id, and another registered
        # environment takes none of a scenario's options
        raise ValueError(f"{file}: config.env_id {_shown(config.env_id)} is not registered as "
                         "a scenario of lgmd-sim, the only environments a policy acts in "
                         "(lgmd-sim envs lists them)")


def _shown(value: Any) -> str:
    """`value` of a policy.json in a message: its repr, cut short (the file may be large)."""
    return textwrap.shorten(repr(value), 100)


def _read_config(folder: Path) -> tuple[Path, PolicyConfig, dict[str, Any]]:
    data = read_json(folder / CONFIG_FILE)  # its errors name the file
    try:
        config = PolicyConfig.from_json(data["config"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{folder / CONFIG_FILE} is not a policy configuration ({exc})"
                         ) from None
    if not (isinstance(config.algo, str) and config.algo in ALGOS and config.obs in OBS):
        raise ValueError(f"{folder / CONFIG_FILE}: a policy of {_shown(config.algo)} on "
                         f"{_shown(config.obs)}, not one of {', '.join(ALGOS)} on "
                         f"{', '.join(OBS)}")
    return folder, config, data


def load(path: str | os.PathLike, plugins: Collection[str] = ()) -> LoadedPolicy:
    """The policy at `path` (see `resolve`), its network on the CPU: built from
    policy.json's architecture and the spaces of the environment as the policy observes
    it (`lgmd_sim.policies.observe`), its weights from policy.npz; nothing is unpickled,
    and nothing policy.json names is imported unless the user names it (`plugins`: see
    `load_config`).

    Raises:
        ValueError: weights that are not plain arrays of the network's names and shapes
            (refused from the arrays' headers, before any is read), or not finite; a
            policy.json naming what `load_config` refuses, or whose network, statistics
            or observation this cannot rebuild (one line naming the file).
    """
    from lgmd_sim.policies.observe import base_env, observe

    folder, config, data = load_config(path, plugins)
    sb3 = require("stable_baselines3", "rl")
    import torch

    normalize = _normalizer(folder, data)
    network = data.get("network") or {}
    aliases = getattr(sb3, ALGOS[config.algo]).policy_aliases
    if network.get("policy") not in aliases or not isinstance(network.get("kwargs"), dict):
        raise ValueError(f"{folder / CONFIG_FILE}: its \"network\" is not a stable-baselines3 "
                         f"policy of {config.algo} ({', '.join(aliases)}) with its keyword "
                         "arguments")
    try:
        with closing(base_env(config)) as base:
            env = observe(base, config)
            spaces = (env.observation_space, env.action_space)
    except ValueError as exc:  # its sizes, model or preset, checked before they are made
        raise ValueError(f"{folder / CONFIG_FILE}: config: {exc}") from None
    shapes = {k: s.shape for k, s in spaces[0].spaces.items()}
    if normalize.mean.keys() != normalize.var.keys() or any(
            shapes.get(k) != s[k].shape for s in (normalize.mean, normalize.var) for k in s):
        raise ValueError(f"{folder / CONFIG_FILE}: its \"normalize\" statistics do not fit the "
                         f"observations of {config.env_id} ({shapes})")
    try:
        policy = aliases[network["policy"]](*spaces, lambda _: 0.0, **network["kwargs"])
    except (TypeError, ValueError, RuntimeError, KeyError, AttributeError, AssertionError
            ) as exc:  # the architecture's arguments, as stable-baselines3 and torch refuse them
        raise ValueError(f"{folder / CONFIG_FILE}: its \"network\" cannot be built in "
                         f"{config.env_id} as it is now ({textwrap.shorten(str(exc), 300)})"
                         ) from None
    weights = _weights(folder / MODEL_FILE, {k: v.numpy() for k, v in
                                             policy.state_dict().items()})
    policy.load_state_dict({k: torch.from_numpy(v) for k, v in weights.items()})
    policy.set_training_mode(False)
    return LoadedPolicy(folder, config, policy, normalize, data.get("trained", {}))


def _normalizer(folder: Path, data: Mapping[str, Any]) -> Normalizer:
    """The observation statistics of policy.json's `data`, in `folder`."""
    try:
        return Normalizer.from_json(data.get("normalize"))
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        # a check's own message names the statistic; Python's name only the key or type
        detail = exc if type(exc) is ValueError else repr(exc)
        raise ValueError(f"{folder / CONFIG_FILE}: its \"normalize\" is not observation "
                         f"statistics ({detail})") from None


#: The readers of the .npy format versions that hold plain arrays (3.0 adds only UTF-8
#: field names, of structured arrays, which no network has).
_HEADERS = {(1, 0): npy.read_array_header_1_0, (2, 0): npy.read_array_header_2_0}


def _weights(file: Path, network: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The arrays of `file`, which must be those of `network` (name -> array): the same
    names, each of the same shape and dtype, as its header (checked before the array is
    read: a declared size allocates nothing) says. Anything else (a pickle, an object
    array, another shape) is refused, as are values that are not finite."""
    arrays = {}
    try:
        with zipfile.ZipFile(file) as z:
            names, wanted = sorted(z.namelist()), sorted(f"{k}.npy" for k in network)
            if names != wanted:
                raise ValueError(f"its arrays are not the network's: missing "
                                 f"{sorted(set(wanted) - set(names)) or 'none'}, not the "
                                 f"network's {sorted(set(names) - set(wanted)) or 'none'}")
            for key, want in network.items():
                with z.open(f"{key}.npy") as f:
                    version = npy.read_magic(f)
                    if version not in _HEADERS:
                        raise ValueError(f"array {key!r}: .npy format {version}, not a plain "
                                         "array's")
                    shape, _, dtype = _HEADERS[version](f)
                if (shape, dtype) != (want.shape, want.dtype):
                    raise ValueError(f"array {key!r} is {dtype} {shape}, the network's "
                                     f"{want.dtype} {want.shape}")
                with z.open(f"{key}.npy") as f:
                    arrays[key] = npy.read_array(f, allow_pickle=False)
    except (OSError, ValueError, EOFError, RuntimeError, NotImplementedError,
            zipfile.BadZipFile, zlib.error) as exc:  # RuntimeError, NotImplementedError:
        # an encrypted member, or a compression zipfile does not read
        raise ValueError(f"{file} is not a policy's weights, arrays as lgmd-sim train writes "
                         f"them for the network of {CONFIG_FILE} "
                         f"({textwrap.shorten(str(exc), 300)})") from None
    for key, array in arrays.items():
        if not np.isfinite(array).all():
            raise ValueError(f"{file}: array {key!r} holds values that are not finite (NaN or "
                             "infinity), which no trained network has")
    return arrays


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
