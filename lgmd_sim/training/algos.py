"""The policy kinds: each algorithm's hyperparameters per observation kind.

Every observation kind is a Dict, so all use stable-baselines3's ``MultiInputPolicy``:
an MLP over the concatenated vectors for "features" and "privileged", a CNN (NatureCNN)
on the stacked frames beside an MLP input for the proprioception and goal for "pixels".
"privileged" takes the values of "features" (vectors of about the same size), with
longer PPO rollouts: without frames to render its steps are cheap. Values follow
RL Baselines3 Zoo's for continuous control, sized for two CPU cores: small networks (64 x
64 units: fast updates, and a policy that ships in a few hundred KB), short rollouts,
and for SAC a replay buffer that fits in memory with frames.
"""

from __future__ import annotations

import ast
import copy
import inspect
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from lgmd_sim.core.extras import require
from lgmd_sim.core.params import FieldError

__all__ = ["HYPERPARAMETERS", "hyperparameters", "make_model", "parse_overrides"]

_PPO_FEATURES: dict[str, Any] = {
    "n_steps": 1024, "batch_size": 256, "n_epochs": 10, "learning_rate": 3e-4,
    "gamma": 0.99, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0,
    "policy_kwargs": {"net_arch": [64, 64]},
}
_SAC_FEATURES: dict[str, Any] = {
    "buffer_size": 200_000, "learning_starts": 2_000, "batch_size": 256,
    "train_freq": 1, "gradient_steps": 1, "learning_rate": 3e-4, "gamma": 0.99,
    "tau": 0.005, "ent_coef": "auto_0.1", "policy_kwargs": {"net_arch": [64, 64]},
}

#: (algo, obs) -> constructor keyword arguments (besides policy, env, seed).
HYPERPARAMETERS: dict[tuple[str, str], dict[str, Any]] = {
    ("ppo", "features"): _PPO_FEATURES,
    ("ppo", "pixels"): {
        "n_steps": 256, "batch_size": 128, "n_epochs": 4, "learning_rate": 2.5e-4,
        "gamma": 0.99, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 0.0,
    },
    # deep copies: no entry shares its policy_kwargs with another
    ("ppo", "privileged"): {**copy.deepcopy(_PPO_FEATURES), "n_steps": 2048},
    ("sac", "features"): _SAC_FEATURES,
    ("sac", "pixels"): {
        # 4 x 60 x 80 frames: 10,000 transitions (observation and next) take about 400 MB
        "buffer_size": 10_000, "learning_starts": 1_000, "batch_size": 64,
        "train_freq": 1, "gradient_steps": 1, "learning_rate": 3e-4, "gamma": 0.99,
        "tau": 0.005, "ent_coef": "auto_0.1",
    },
    ("sac", "privileged"): copy.deepcopy(_SAC_FEATURES),
}


#: Constructor arguments the run sets itself (`make_model`), never a hyperparameter.
_SET_BY_THE_RUN = {"self", "policy", "env", "seed", "device", "verbose", "_init_setup_model"}
#: How a message names the value a type annotation asks for.
_NAMES = {bool: "True or False", int: "an integer", float: "a number", str: "a string",
          dict: "a dict", tuple: "a tuple", list: "a list", type(None): "None"}


def _fits(value: Any, annotation: Any) -> bool:
    """Whether `value` (a Python literal) is of the type `annotation` asks for; a type
    this cannot read (a forward reference) takes anything."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if annotation in (inspect.Parameter.empty, Any) or isinstance(
            annotation, str | typing.ForwardRef):
        return True
    if origin in (typing.Union, types.UnionType):
        return any(_fits(value, a) for a in args)
    if annotation is float:  # an integer is a number too, as stable-baselines3 takes it
        return isinstance(value, int | float) and not isinstance(value, bool)
    if annotation is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if origin is Callable:  # a schedule: no literal is one
        return callable(value)
    if origin is tuple and args and Ellipsis not in args:
        return (isinstance(value, tuple) and len(value) == len(args)
                and all(_fits(v, a) for v, a in zip(value, args, strict=True)))
    if origin is type:  # a class: no literal is one
        return False
    return isinstance(value, origin or annotation)


def _expected(annotation: Any) -> str:
    """What `annotation` asks for, in words ("a number", "an integer or a tuple")."""
    members = (typing.get_args(annotation) if typing.get_origin(annotation) in (
        typing.Union, types.UnionType) else (annotation,))
    names = [_NAMES.get(typing.get_origin(m) or m) for m in members]
    return " or ".join(dict.fromkeys(n for n in names if n)) or str(annotation)


def _not_json(value: Any) -> str | None:
    """The first part of `value` (a Python literal) that JSON does not hold as it is: a
    set, bytes, a complex number, a key that is not a string (JSON would make it one);
    None if there is none."""
    if isinstance(value, dict):
        keys = [k for k in value if not isinstance(k, str)]
        return f"the key {keys[0]!r}" if keys else _not_json(list(value.values()))
    if isinstance(value, list | tuple):
        return next(filter(None, map(_not_json, value)), None)
    return None if value is None or isinstance(value, str | int | float) else repr(value)


def parse_overrides(items: Iterable[str], algo: str) -> dict[str, Any]:
    """``KEY=VALUE`` overrides of `algo`'s constructor arguments, each value a Python
    literal (``n_steps=64``, ``policy_kwargs={'net_arch': [32, 32]}``) of the type the
    constructor declares for it; ``policy_kwargs`` go to the policy folder's policy.json,
    so they must be JSON.

    Raises:
        ValueError: not KEY=VALUE, a key the algorithm does not take (or the run sets),
            a value of another type, or policy_kwargs that are not JSON.
    """
    from lgmd_sim.policies.folder import ALGOS

    cls = getattr(require("stable_baselines3", "rl"), ALGOS[algo])
    taken = {name: p.annotation for name, p in inspect.signature(cls.__init__).parameters.items()
             if name not in _SET_BY_THE_RUN}
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep:
            raise ValueError(f"hyperparameter {item!r} is not KEY=VALUE")
        if key not in taken:
            raise ValueError(f"unknown hyperparameter {key!r} for {algo}")
        try:
            value = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            value = text  # a plain word: a string ("auto")
        if not _fits(value, taken[key]):
            raise FieldError("hp", f"holds {item}: {algo}'s {key} must be "
                             f"{_expected(taken[key])}")
        # checked now, not when the first policy is saved after training
        if key == "policy_kwargs" and (part := _not_json(value)):
            raise FieldError("hp", f"holds {item}: {algo}'s policy_kwargs must be JSON "
                             "(policy.json holds them): strings, numbers, lists and dicts "
                             f"with string keys, not {part}")
        out[key] = value
    return out


def hyperparameters(algo: str, obs: str, overrides: Mapping[str, Any] | None = None
                    ) -> dict[str, Any]:
    """The constructor arguments of (algo, obs) with `overrides` on top."""
    # a deep copy: SAC's constructor writes use_sde into the policy_kwargs it is given
    return copy.deepcopy({**HYPERPARAMETERS[(algo, obs)], **(overrides or {})})


def make_model(algo: str, venv: Any, kwargs: Mapping[str, Any], seed: int) -> Any:
    """A new stable-baselines3 model of `algo` on `venv` (on the CPU); ValueError where
    the library refuses a hyperparameter's value (``batch_size=1``, ``learning_rate=-1``,
    ``policy_kwargs={'foo': 1}``)."""
    from lgmd_sim.policies.folder import ALGOS

    cls = getattr(require("stable_baselines3", "rl"), ALGOS[algo])
    try:
        return cls("MultiInputPolicy", venv, seed=seed, device="cpu", verbose=0, **kwargs)
    # stable-baselines3 (and PyTorch's optimiser, the policy's constructor) check the
    # values this way
    except (AssertionError, ValueError, TypeError) as exc:
        raise FieldError("hp", f"holds hyperparameters {algo} refuses: "
                         f"{' '.join(str(exc).split())}") from None
