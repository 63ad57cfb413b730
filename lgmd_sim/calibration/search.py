"""What the calibration searches: each model's free parameters, sampled with the same
budget for every model, and the evaluation of one candidate on the recorded clips.

The alarm threshold is free for every model, and costs nothing to search: one run of a
candidate gives its potentials, and every threshold of `THRESHOLDS` is scored from them by
the task's objective (`lgmd_sim.calibration.objective.Objective`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.calibration.clips import FRONT_ENDS, load_clip, load_truth
from lgmd_sim.calibration.objective import THRESHOLDS, WALKER, Objective

__all__ = ["SPACES", "THRESHOLDS", "Candidate", "candidates", "evaluate"]


def _log_uniform(lo: float, hi: float) -> Callable[[np.random.Generator], float]:
    return lambda rng: float(np.exp(rng.uniform(math.log(lo), math.log(hi))))


def _feedback(rng: np.random.Generator) -> dict[str, Any]:
    """The feedback LGMD's free parameters (docs/models.md, choices 2-9), loop closed."""
    eta1 = _log_uniform(0.5, 200.0)(rng)
    return {
        "feedback_gain": _log_uniform(1.0, 1e6)(rng),
        "rho": _log_uniform(0.01, 10.0)(rng),
        "eta": (eta1, eta1 * rng.uniform(1.5, 4.0)),
        "zeta": (rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0)),
        "tv_window": int(rng.choice([3, 5, 8, 12])),
        "k_mode": str(rng.choice(["constant", "potential"])),
        "mu": _log_uniform(0.3, 10.0)(rng),
    }


def _open_loop(rng: np.random.Generator) -> dict[str, Any]:
    """The feedback LGMD with its loop open (`FIXED`): only the sigmoid scale is left."""
    return {"mu": _log_uniform(0.3, 10.0)(rng)}


def _scale(rng: np.random.Generator) -> dict[str, Any]:
    """A baseline's sigmoid coefficient (its threshold is searched as for every model)."""
    return {"c_sig": _log_uniform(0.1, 100.0)(rng)}


#: Parameters every candidate of a detector has, its starting one included.
FIXED: dict[str, dict[str, Any]] = {"feedback-open-loop": {"feedback_gain": 0.0}}
_BASES: dict[str, tuple[str, str, Callable[[np.random.Generator], dict[str, Any]]]] = {
    "feedback": ("feedback", "paper", _feedback),
    "feedback-open-loop": ("feedback", "paper", _open_loop),
    "lgmd1": ("lgmd1", "published", _scale),
    "lgmd2": ("lgmd2", "published", _scale),
    "f_on": ("f_on", "published", _scale),
    "f_off": ("f_off", "published", _scale),
}
#: Per calibrated detector ("lgmd1", or with a front end "lgmd1+image"): the model, the
#: preset the candidates start from, the sampler of the parameters searched, and the front
#: end (None, or one of `FRONT_ENDS`).
SPACES: dict[str, tuple[str, str, Callable[[np.random.Generator], dict[str, Any]],
                        str | None]] = {
    **{key: (*base, None) for key, base in _BASES.items()},
    **{f"{key}+{front}": (*base, front) for key, base in _BASES.items()
       for front in FRONT_ENDS},
}


@dataclass(frozen=True)
class Candidate:
    """One parameter setting of a detector."""

    detector: str  # a key of SPACES
    index: int  # 0 is the starting preset itself
    params: Mapping[str, Any]

    @property
    def key(self) -> str:
        return f"{self.detector}-{self.index:03d}"


def candidates(detector: str, budget: int, seed: int) -> list[Candidate]:
    """The starting preset and `budget` - 1 samples of the detector's space (seeded)."""
    _model, _preset, sample, _front = SPACES[detector]
    fixed = FIXED.get(detector.split("+")[0], {})
    rng = np.random.default_rng([seed, sum(map(ord, detector))])
    return [Candidate(detector, 0, dict(fixed))] + [
        Candidate(detector, i, {**fixed, **sample(rng)}) for i in range(1, budget)]


def evaluate(candidate: Candidate, folder: str, clip_sets: Mapping[str, Sequence[dict]],
             objective: Objective = WALKER) -> dict[str, Any]:
    """Run a candidate over every clip; per set, its scores by `objective` at every
    threshold (a job)."""
    from lgmd_sim import models
    from lgmd_sim.models.warp import Motion

    name, preset, _, front = SPACES[candidate.detector]
    out: dict[str, Any] = {"detector": candidate.detector, "index": candidate.index,
                           "params": dict(candidate.params), "sets": {}}
    for set_name, records in clip_sets.items():
        clips = [load_clip(folder, rec["key"], front) for rec in records]
        # One batched model runs every clip of the set as its own stream (bit-identical to
        # separate streams); a clip that has ended repeats its last frame, unread. A front
        # end's motions were computed once, with the clip (`clips.clip_motions`).
        model = models.make(name, preset=preset, n_streams=len(clips), **candidate.params)
        lengths = np.array([len(frames) for frames, _ in clips])
        potentials = np.empty((len(clips), lengths.max()))
        for t in range(lengths.max()):
            at = [min(t, n - 1) for n in lengths]
            motion = None if front is None else Motion(
                np.stack([hs[i] for (_, hs), i in zip(clips, at, strict=True)]))
            frames = np.stack([f[i] for (f, _), i in zip(clips, at, strict=True)])
            potentials[:, t] = model.step(frames, motion=motion).potential
        labels = [objective.label(r, load_truth(folder, r["key"], objective.truth))
                  for r in records]
        out["sets"][set_name] = objective.scores(
            labels, [p[:n] for p, n in zip(potentials, lengths, strict=True)], THRESHOLDS)
    return out
