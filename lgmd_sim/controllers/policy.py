"""`Policy`: a policy trained with `lgmd-sim train`, as a controller."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from lgmd_sim.controllers.base import Controller
from lgmd_sim.controllers.straight import DESIGN
from lgmd_sim.core.params import CheckedParams, comma_list, param

__all__ = ["Policy", "PolicyParams"]


def _text(v: Any) -> str | None:
    return None if isinstance(v, str) and v else "must be a folder or a shipped policy's name"


def _specs(v: Any) -> str | None:
    return None if isinstance(v, str) else "must be comma-separated 'package.module:Class' specs"


def _shapes(space: gym.spaces.Dict) -> dict[str, tuple[int, ...]]:
    return {k: s.shape for k, s in space.spaces.items()}


@dataclass(frozen=True)
class PolicyParams(CheckedParams):
    path: str = param("shipped", DESIGN, check=_text,
                      doc="a policy folder (policy.npz and policy.json, as lgmd-sim train "
                          "writes it), or a shipped policy's name ('shipped': the default)")
    plugins: str = param("", DESIGN, check=_specs,
                         doc="plug-in model specs, comma-separated, that the policy may "
                             "observe: a policy names only built-in, registered or installed "
                             "models otherwise, since a spec is imported (lgmd-sim bench "
                             "closed-loop --policies passes those of its --models)")


class Policy(Controller):
    """A trained stable-baselines3 policy, acting deterministically.

    `wrap_env` applies the observation pipeline the policy was trained with (the LGMD
    wrapper's features, stacked small grey frames, or the threat's ground truth from
    ``info``; read from its policy.json), and `act` normalises the observation with the
    training statistics, frozen, and takes the action ``predict(obs, deterministic=True)``
    gives. A policy on vectors (LGMD features, ground truth) computes it in
    `lgmd_sim.policies.forward`, in an order of its own, so that its episodes give the
    same bits on any x86-64 processor with AVX2 (in the replay numeric mode,
    `lgmd_sim.core.numerics`); one that module does not cover (a pixel policy's CNN) keeps
    stable-baselines3's ``predict``, whose PyTorch kernels sum in an order that depends on
    the processor: its episodes replay only on processors of the same kind. The
    environment must be the one it was trained in (same id, frame size): `wrap_env`
    refuses another frame size, but for a privileged policy, which reads no frames
    (trained frameless, it acts on a rendering environment of any size alike). ``alarm``
    is the observed LGMD model's alarm on the frame (False for a pixel or privileged
    policy), so that the benchmark's false-alarm columns describe the detector the policy
    reads.
    ``manoeuvring`` stays None: the policy turns away without naming it a manoeuvre.
    """

    Params = PolicyParams
    params: PolicyParams

    def __init__(self, **params: Any) -> None:
        from lgmd_sim import policies
        from lgmd_sim.policies import forward

        super().__init__(**params)
        self.policy = policies.load(self.params.path, comma_list(self.params.plugins))
        self.forward = forward.build(self.policy.network)
        # one thread for torch's forward pass where it runs (a policy `forward` does not
        # cover): a small network, and one controller per core in a sweep
        import torch

        torch.set_num_threads(1)

    def wrap_env(self, env: gym.Env) -> gym.Env:
        from lgmd_sim.policies.observe import observe

        trained = self.policy.config.trained_frames()
        size = tuple(env.unwrapped.params.size)
        if trained not in (None, size):
            raise ValueError(f"policy {self.policy.name} was trained on {trained[0]}x"
                             f"{trained[1]} frames, this environment renders {size[0]}x"
                             f"{size[1]}: run it at resolution "
                             f"{self.policy.config.resolution}")
        wrapped = observe(env, self.policy.config)
        seen, trained = (_shapes(wrapped.observation_space),
                         _shapes(self.policy.network.observation_space))
        if seen != trained:
            raise ValueError(f"policy {self.policy.name} was trained on observations {trained}, "
                             f"this environment gives {seen}: it changed since; retrain")
        return wrapped

    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        if "lgmd_alarm" in obs:
            self.alarm = bool(obs["lgmd_alarm"].any())
        normalized = self.policy.normalize(obs)
        if self.forward is not None:
            return self.forward(normalized)
        action, _ = self.policy.network.predict(normalized, deterministic=True)
        return np.asarray(action, np.float32)
