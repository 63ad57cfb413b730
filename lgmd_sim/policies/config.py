"""What a policy folder records besides the network: `PolicyConfig` (the environment a
policy was trained in and the observation pipeline it sees) and `Normalizer` (its
observation normalisation, frozen). Both are plain data, to and from policy.json.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

__all__ = ["Normalizer", "PolicyConfig"]


@dataclass(frozen=True)
class PolicyConfig:
    """The environment a policy was trained in and the observation pipeline it sees.

    Attributes:
        algo: a key of `lgmd_sim.policies.folder.ALGOS`.
        obs: "features" (an LGMD model's potentials, alarm and S-layer grid with the
            proprioception and goal; an MLP policy), "pixels" (the last `frame_stack`
            grey frames at `frame_size` with the proprioception and goal; a CNN policy)
            or "privileged" (the threat's ground truth with the proprioception and goal;
            an MLP policy).
        env_id: the Gymnasium id of the environment.
        resolution: the frame size the environment renders (a preset name or [H, W]).
        jitter: the jitter level it was trained at.
        model, preset: the LGMD model and its preset (features).
        history, grid, grid_history: the potentials observed, the S-layer grid and how
            many of the last grids are observed (features).
        memory: frames the per-column memory of the excitation lasts, 0 for none
            (features; `lgmd_sim.envs.wrappers.LGMDFeatures`).
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
    grid_history: int = 1
    memory: int = 0
    frame_size: tuple[int, int] = (60, 80)
    frame_stack: int = 4

    def to_json(self) -> dict[str, Any]:
        return json.loads(json.dumps(asdict(self)))

    def trained_frames(self) -> tuple[int, int] | None:
        """The (height, width) of the frames the policy was trained on, which it must run
        on; None for a privileged policy, which observes no frame."""
        from lgmd_sim.world.params import frame_size

        return None if self.obs == "privileged" else frame_size(self.resolution)

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
        """The statistics `to_json` wrote (None: the identity).

        Raises:
            ValueError: a mean or variance that is not finite, a negative variance, or a
                clip or epsilon that is not a finite number > 0, naming it: each would
                turn the observations into NaN (or clip them all to 0) inside the network,
                where nothing names the statistics.
        """
        if not data:
            return cls()
        mean = {k: np.asarray(v, float) for k, v in data["mean"].items()}
        var = {k: np.asarray(v, float) for k, v in data["var"].items()}
        for what, stats in (("mean", mean), ("var", var)):
            for k, v in stats.items():
                if not np.isfinite(v).all():
                    raise ValueError(f"{what}[{k!r}] holds a value that is not finite")
        for k, v in var.items():
            if (v < 0).any():
                raise ValueError(f"var[{k!r}] holds a negative variance")
        clip, epsilon = float(data["clip"]), float(data["epsilon"])
        for what, value in (("clip", clip), ("epsilon", epsilon)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{what} must be a finite number > 0, got {value}")
        return cls(mean, var, clip, epsilon)
