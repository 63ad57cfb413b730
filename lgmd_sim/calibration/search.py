"""What the calibration searches: each model's free parameters, as its class declares them
(`lgmd_sim.models.base.LGMDModel.search_space`), sampled with the same budget for every
model, and the evaluation of one candidate on the recorded clips.

A detector is a model whose class declares a search space (a name, or a plug-in's
"package.module:Class" spec), its candidates starting from its default preset, or the
feedback LGMD's open-loop control (`CONTROLS`); either with a front end of `FRONT_ENDS`
or not ("lgmd1+image", "lgmd1+image+gain").

The alarm threshold is free for every model, and costs nothing to search: one run of a
candidate gives its potentials, and every threshold of `THRESHOLDS` is scored from them by
the task's objective (`lgmd_sim.calibration.objective.Objective`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim import models
from lgmd_sim.calibration.clips import FRONT_ENDS, load_clip, load_gains, load_truth
from lgmd_sim.calibration.objective import THRESHOLDS, WALKER, Objective
from lgmd_sim.controllers import options
from lgmd_sim.models.search import SearchRange, check_search_space, draw_search

__all__ = ["CONTROLS", "THRESHOLDS", "Candidate", "Space", "candidates", "detector_list",
           "evaluate", "space"]

#: Detectors that are no model of their own: the feedback LGMD with its loop opened (gain
#: 0), the control of what the loop adds, of which only the sigmoid's scale is left to
#: search. Each: the model, the keys of its search space searched, and the parameters
#: every candidate has, its starting one included.
CONTROLS: dict[str, tuple[str, tuple[str, ...], dict[str, Any]]] = {
    "feedback-open-loop": ("feedback", ("mu",), {"feedback_gain": 0.0}),
}


@dataclass(frozen=True)
class Space:
    """What the calibration searches for one detector (`space`).

    Attributes:
        model: the model's name or spec.
        preset: the preset the candidates start from, the model's default.
        ranges: the keys searched, in the order they are drawn.
        fixed: the parameters every candidate has.
        front: None, or the front end of `FRONT_ENDS` every candidate runs with.
    """

    model: str
    preset: str
    ranges: Mapping[str, SearchRange]
    fixed: Mapping[str, Any]
    front: str | None

    def sample(self, rng: np.random.Generator) -> dict[str, Any]:
        """One candidate's parameters (`lgmd_sim.models.search.draw_search`), with the fixed
        ones."""
        return {**self.fixed, **draw_search(self.ranges, rng)}


def space(detector: str) -> Space:
    """The search of a detector: a model or a key of `CONTROLS`, optionally with a front
    end ("+image", "+imu", "+image+gain").

    Raises:
        ValueError: an unknown model, a bad spec or front end, or a model that declares
            no search space (one line, naming it).
    """
    head, plus, front = detector.partition("+")
    if plus and front not in FRONT_ENDS:
        raise ValueError(f"detector {detector!r}: the calibration's front ends are "
                         f"{', '.join('+' + f for f in FRONT_ENDS)}")
    model, searched, fixed = CONTROLS.get(head, (head, (), {}))
    cls = models.model_class(model)
    if not cls.search_space:
        raise ValueError(f"model {model!r} declares no search_space: the calibration has "
                         "nothing to tune")
    check_search_space(model, cls.Params, cls.search_space)
    ranges = dict(cls.search_space)
    if searched:
        ranges = {key: ranges[key] for key in searched}
    return Space(model, next(iter(cls.presets)), ranges, dict(fixed), front or None)


def detector_list(given: str | Sequence[str] | None = None,
                  fronts: Sequence[str | None] = (None, "image", "imu")) -> list[str]:
    """The detectors to calibrate, each checked (`space`): those `given` (a
    comma-separated list or a sequence: models by name or spec, keys of `CONTROLS`, each
    with or without a front end), or, for None or "all", every model of
    `lgmd_sim.models.available()` whose class declares a search space, each followed by
    its controls, all of them with each of `fronts` in turn (None: no front end)."""
    named = [n for m in models.available()
             for n in (m, *(c for c, (of, _, _) in CONTROLS.items() if of == m))]
    listed = None if given is None else (
        options.comma_list(given) if isinstance(given, str) else list(given))
    if listed in (None, ["all"]):
        return _with_fronts([n for n in named if models.model_class(
            CONTROLS.get(n, (n,))[0]).search_space], fronts)
    valid = _with_fronts(named, (None, *FRONT_ENDS))
    chosen = options.names(listed, valid, "detector(s)", load=space)  # checks the specs
    for d in chosen:
        if d in valid:
            space(d)  # a model named without a search space fails here
    return chosen


def _with_fronts(names: list[str], fronts: Sequence[str | None]) -> list[str]:
    return ((names if None in fronts else [])
            + [f"{n}+{front}" for n in names for front in fronts if front is not None])


@dataclass(frozen=True)
class Candidate:
    """One parameter setting of a detector."""

    detector: str  # a detector of `space`
    index: int  # 0 is the starting preset itself
    params: Mapping[str, Any]

    @property
    def key(self) -> str:
        """Its record name (a file name: `lgmd_sim.controllers.options.file_key`)."""
        return options.file_key(f"{self.detector}-{self.index:03d}")


def candidates(detector: str, budget: int, seed: int) -> list[Candidate]:
    """The starting preset and `budget` - 1 samples of the detector's space (seeded)."""
    sp = space(detector)
    rng = np.random.default_rng([seed, sum(map(ord, detector))])
    return [Candidate(detector, 0, dict(sp.fixed))] + [
        Candidate(detector, i, sp.sample(rng)) for i in range(1, budget)]


def evaluate(candidate: Candidate, folder: str, clip_sets: Mapping[str, Sequence[dict]],
             objective: Objective = WALKER) -> dict[str, Any]:
    """Run a candidate over every clip; per set, its scores by `objective` at every
    threshold (a job)."""
    from lgmd_sim.models.stabilize import gain_field
    from lgmd_sim.models.warp import Motion

    sp = space(candidate.detector)
    name, preset, front = sp.model, sp.preset, sp.front
    out: dict[str, Any] = {"detector": candidate.detector, "index": candidate.index,
                           "params": dict(candidate.params), "sets": {}}
    for set_name, records in clip_sets.items():
        clips = [load_clip(folder, rec["key"], front) for rec in records]
        gains = [load_gains(folder, rec["key"], front) for rec in records] if front else []
        # One batched model runs every clip of the set as its own stream (bit-identical to
        # separate streams); a clip that has ended repeats its last frame, unread. A front
        # end's motions were computed once, with the clip (`clips.clip_motions`).
        model = models.make(name, preset=preset, n_streams=len(clips), **candidate.params)
        lengths = np.array([len(frames) for frames, _ in clips])
        potentials = np.empty((len(clips), lengths.max()))
        for t in range(lengths.max()):
            at = [min(t, n - 1) for n in lengths]
            frames = np.stack([f[i] for (f, _), i in zip(clips, at, strict=True)])
            motion = None if front is None else Motion(
                np.stack([hs[i] for (_, hs), i in zip(clips, at, strict=True)]),
                None if gains[0] is None else np.stack(
                    [gain_field(g[i], frames.shape[1:]) for g, i in zip(gains, at, strict=True)]))
            potentials[:, t] = model.step(frames, motion=motion).potential
        labels = [objective.label(r, load_truth(folder, r["key"], objective.truth))
                  for r in records]
        out["sets"][set_name] = objective.scores(
            labels, [p[:n] for p, n in zip(potentials, lengths, strict=True)], THRESHOLDS)
    return out
