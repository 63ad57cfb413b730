"""A trained policy's deterministic action, computed in an order this code fixes, so that an
episode it drives gives the same bits on any x86-64 processor with AVX2.

stable-baselines3's ``predict`` runs the network in PyTorch, whose matrix kernels choose
their vector width and the order of their sums by the processor: the same observation
gives actions that differ in the last bits from one processor to another, and a closed
loop grows that into another episode. `build` reads a loaded policy's network once and
returns a `Forward` that computes what ``predict(obs, deterministic=True)`` computes:

- the features extractor: each observation key flattened, in the extractor's key order,
  and concatenated (``FlattenExtractor``, or ``CombinedExtractor`` over vectors only);
- the layers: `dense` (a Numba kernel that adds its products in a fixed order), then
  NumPy's tanh, ReLU (maximum) or Hardtanh (clip) as the network has them;
- the action: PPO's mean (its distribution's mode), SAC's mean through tanh, then as
  ``predict`` finishes a Box action: clipped to the bounds, or a tanh-squashed action
  rescaled to them.

It covers PPO's and SAC's policies on vector observations (the "features" and
"privileged" ones of `lgmd_sim.policies.folder.OBS`). Anything else (a CNN on frames, the
"pixels" policies; another extractor, layer or distribution) gets None: such a policy
keeps ``predict``, and its episodes replay only on processors of the same kind.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from numba import njit

from lgmd_sim.models.kernels import JIT

__all__ = ["Dense", "Forward", "build", "dense"]

#: One step of the network: float32 vector in, float32 vector out.
Layer = Callable[[np.ndarray], np.ndarray]


@njit(**JIT)
def dense(weight: np.ndarray, bias: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = bias[i] + weight[i, 0] x[0] + weight[i, 1] x[1] + ...``, added left to
    right: a dense layer's ``x @ weight.T + bias`` in a fixed order.

    float32 arrays; ``x`` of ``weight.shape[1]`` values and ``out`` of ``weight.shape[0]``
    (unchecked here: `Dense` checks them). The sum accumulates in float64, each output
    rounded to float32 once, at the end: the product of two float32 values is exact in
    float64 (48 significant bits of 53), so the only roundings are the additions', in the
    order written, and whether the compiler fuses a multiply-add cannot change a bit; the
    result is also closer to the exact sum than a float32 accumulation, so it stays within
    float32 roundoff of PyTorch's whatever order PyTorch chose. `JIT` forbids
    reassociation, so no processor's build reorders the additions.
    """
    for i in range(weight.shape[0]):
        acc = np.float64(bias[i])
        for j in range(weight.shape[1]):
            acc += np.float64(weight[i, j]) * np.float64(x[j])
        out[i] = np.float32(acc)


@dataclass(frozen=True, eq=False)
class Dense:
    """A linear layer (torch's ``nn.Linear``) computed by `dense`: float32 ``weight``
    (outputs x inputs) and ``bias``."""

    weight: np.ndarray
    bias: np.ndarray

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The layer's output for the float32 vector `x`.

        Raises:
            ValueError: `x` is not a vector of the layer's input size (`dense` reads
                ``weight.shape[1]`` values of it, unchecked).
        """
        if x.shape != (self.weight.shape[1],):
            raise ValueError(f"the network takes {self.weight.shape[1]} features, not "
                             f"{x.shape}")
        out = np.empty(self.weight.shape[0], np.float32)
        dense(self.weight, self.bias, x, out)
        return out


@dataclass(frozen=True, eq=False)
class _Clip:
    """torch's ``nn.Hardtanh`` (SAC's mean under gSDE): `x` clipped to [low, high]."""

    low: np.float32
    high: np.float32

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.clip(x, self.low, self.high)


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, np.float32(0.0))


@dataclass(frozen=True, eq=False)
class Forward:
    """The deterministic action of a policy's network (`build` makes one).

    Attributes:
        keys: the observation keys the features extractor concatenates, in its order;
            None for a Box observation (one array).
        layers: the network, features to the distribution's mean.
        squash: whether the action is the mean through tanh, rescaled to the bounds
            (SAC, and PPO with a squashed gSDE); else the mean clipped to them.
        low, high: the action space's bounds (float32, its shape).
    """

    keys: tuple[str, ...] | None
    layers: tuple[Layer, ...]
    squash: bool
    low: np.ndarray
    high: np.ndarray

    def features(self, obs: Mapping[str, np.ndarray] | np.ndarray) -> np.ndarray:
        """The features extractor's output for one observation: each key as float32 (as
        stable-baselines3's ``obs.float()``), flattened, concatenated."""
        if self.keys is None:
            return np.asarray(obs, np.float32).reshape(-1)
        return np.concatenate([np.asarray(obs[k], np.float32).reshape(-1) for k in self.keys])

    def __call__(self, obs: Mapping[str, np.ndarray] | np.ndarray) -> np.ndarray:
        """The action ``predict(obs, deterministic=True)`` gives for one (normalised)
        observation, float32, of the action space's shape.

        Raises:
            ValueError: an observation of another size than the network takes.
        """
        x = self.features(obs)
        for layer in self.layers:
            x = layer(x)
        x = x.reshape(self.low.shape)
        # NumPy's tanh, like every ufunc here, runs the kernels NumPy dispatches to by the
        # processor; the replay mode pins them (lgmd_sim.core.numerics), so it gives the
        # same bits on every processor with AVX2
        if self.squash:  # stable-baselines3's unscale_action, on the same float32 arrays
            return self.low + (0.5 * (np.tanh(x) + 1.0) * (self.high - self.low))
        return np.clip(x, self.low, self.high)


class _Uncovered(Exception):
    """A part of the network `Forward` does not compute."""


def build(network: Any) -> Forward | None:
    """The `Forward` of a stable-baselines3 policy (`lgmd_sim.policies.LoadedPolicy`'s
    ``network``, in evaluation mode): weights copied now, so it acts as the network did
    when built. None for a network it does not cover: not PPO's or SAC's policy, a
    features extractor other than flattening vectors (a CNN on frames), a layer other
    than linear, tanh, ReLU or Hardtanh, parameters not float32, or an action space not
    a Box."""
    from stable_baselines3.common.distributions import (
        DiagGaussianDistribution,
        StateDependentNoiseDistribution,
    )
    from stable_baselines3.common.policies import ActorCriticPolicy
    from stable_baselines3.sac.policies import SACPolicy

    space = network.action_space
    if not isinstance(space, gym.spaces.Box):
        return None
    if isinstance(network, ActorCriticPolicy) and isinstance(
            network.action_dist, DiagGaussianDistribution | StateDependentNoiseDistribution):
        # deterministic: the distribution's mode, its mean (through tanh where squashed)
        extractor, modules = network.pi_features_extractor, (
            network.mlp_extractor.policy_net, network.action_net)
    elif isinstance(network, SACPolicy):
        # deterministic: tanh of the actor's mean (squash_output is always True)
        extractor, modules = network.actor.features_extractor, (
            network.actor.latent_pi, network.actor.mu)
    else:
        return None
    try:
        keys = _keys(extractor, network.observation_space, network.normalize_images)
        layers = tuple(_layers(modules))
    except _Uncovered:
        return None
    return Forward(keys, layers, bool(network.squash_output),
                   np.asarray(space.low, np.float32), np.asarray(space.high, np.float32))


def _keys(extractor: Any, space: gym.Space, normalize_images: bool
          ) -> tuple[str, ...] | None:
    """`Forward.keys` of a features extractor on observation `space`.

    Raises:
        _Uncovered: an extractor that does more than flatten Box vectors (a CNN; or
            stable-baselines3's preprocessing would scale an image or one-hot a
            discrete value).
    """
    from stable_baselines3.common.preprocessing import is_image_space
    from stable_baselines3.common.torch_layers import CombinedExtractor, FlattenExtractor
    from torch import nn

    def check(sub: gym.Space) -> None:
        if not isinstance(sub, gym.spaces.Box) or (normalize_images and is_image_space(sub)):
            raise _Uncovered

    if type(extractor) is FlattenExtractor:
        check(space)
        return None
    if type(extractor) is CombinedExtractor:
        for key, module in extractor.extractors.items():
            if type(module) is not nn.Flatten:
                raise _Uncovered
            check(space[key])
        return tuple(extractor.extractors)
    raise _Uncovered


def _layers(modules: Iterable[Any]) -> list[Layer]:
    """The `Layer`s of torch `modules` in order, a Sequential's inlined.

    Raises:
        _Uncovered: another module (exact types only: a subclass may compute otherwise),
            or float parameters other than float32.
    """
    import torch
    from torch import nn

    layers: list[Layer] = []
    for module in modules:
        kind = type(module)
        if kind is nn.Sequential:
            layers += _layers(module)
        elif kind is nn.Linear:
            if module.weight.dtype != torch.float32:
                raise _Uncovered
            weight = module.weight.detach().numpy()
            bias = (module.bias.detach().numpy() if module.bias is not None
                    else np.zeros(weight.shape[0], np.float32))
            layers.append(Dense(np.array(weight, np.float32, order="C"),
                                np.array(bias, np.float32)))
        elif kind is nn.Tanh:
            layers.append(np.tanh)
        elif kind is nn.ReLU:
            layers.append(_relu)
        elif kind is nn.Hardtanh:
            layers.append(_Clip(np.float32(module.min_val), np.float32(module.max_val)))
        else:
            raise _Uncovered
    return layers
