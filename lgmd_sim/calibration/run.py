"""`lgmd-sim calibrate`: the same search for every model, judged on clips it never saw.

A task (`lgmd_sim.calibration.tasks.TASKS`) is the clips and the objective they are judged
by: "walker", "robot" or "video".

1. Record the task's clips (`lgmd_sim.calibration.clips`): a search set and a held-out set
   with disjoint seeds, into ``DIR/clips``.
2. Evaluate every candidate of every detector (`lgmd_sim.calibration.search`): the same
   number of candidates each, one job each, records in ``DIR/records`` (resumable).
3. Per detector, choose the candidate and threshold with the best objective on the search
   set; report it on the held-out set beside.
4. Write ``DIR/summary.md``, ``DIR/calibration.png`` (`lgmd_sim.calibration.report`;
   drawn again later by `lgmd_sim.calibration.redraw`) and ``DIR/calibrated.json``: the
   presets with the command, seeds, objective and figure that produced them. With
   ``save_presets`` also merge them into the user's presets file (or ``presets_file``:
   `lgmd_sim.models.presets`), which makes them the models' ``calibrated`` presets (and
   ``calibrated-open-loop`` for the feedback model's open-loop control, gain 0, tuned by
   the same search; the robot task's: ``robot``, ``robot-open-loop``) on top of the
   shipped ones; the other presets there stay.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.calibration import clips as clip_mod
from lgmd_sim.calibration.objective import WALKER, Objective
from lgmd_sim.calibration.report import _sets, calibration_figure, summary_markdown
from lgmd_sim.calibration.search import (
    THRESHOLDS,
    candidates,
    detector_list,
    evaluate,
    space,
)
from lgmd_sim.calibration.tasks import TASKS, preset_name
from lgmd_sim.controllers import options
from lgmd_sim.core.configfile import setting
from lgmd_sim.core.fileio import write_files, write_text_atomic
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.core.params import checked, count, one_of, seed
from lgmd_sim.core.pngtext import png_text
from lgmd_sim.core.runs import NULL, Fields, RunFolder, RunResult
from lgmd_sim.models import presets

__all__ = ["CalibrateConfig", "calibrate", "choose"]


@dataclass(frozen=True)
class CalibrateConfig:
    """What `calibrate` runs, checked when it is made (a bad value raises a one-line
    ValueError naming it). Each field is declared with its meaning
    (`lgmd_sim.core.configfile.setting`): the command line's options and --config keys.
    """

    task: str = setting(
        "walker", "the clips and the objective, a key of `lgmd_sim.calibration.tasks.TASKS`. "
        "walker: the clips of a hand-held, mutual or steady camera and near misses, a hit "
        "when the first alarm comes in the last 15% of an approach; presets calibrated, "
        "calibrated-image ... robot: the robot driving straight over rough ground (jitter "
        "0, 1, 2) at obstacles and where none is in its way, a hit when the first alarm "
        "comes in the avoidance manoeuvre's window and silence while no obstacle is within "
        "2 s (lgmd_sim.calibration.robot); presets robot, robot-imu, robot-image ... "
        "robot-frames: the same, an alarm being 4 rising frames above the threshold (the "
        "video presets' rule); presets robot-frames, robot-frames-image ... video: for "
        "footage from a camera nobody calibrated, the walker's clips and synthetic stimuli "
        "that do not loom (receding, crossing, gratings, flicker: a hit when silent), every "
        "clip with a real camera's noise and the scenes' cameras of 40 to 90 degrees, every "
        "detector with the front end +image+gain (lgmd_sim.calibration.objective.VIDEO); "
        "presets video ...")
    detectors: tuple[str, ...] | None = setting(
        None, "among feedback, feedback-open-loop (the feedback LGMD's open-loop control), "
        "lgmd1, lgmd2, f_on, f_off and any other model whose class declares a search_space "
        "(a registered name or a package.module:Class spec), each also with a front end of "
        "the task's (+image: the rotation fitted from the frames; +imu: the world's IMU; "
        "the video task's +image+gain, given or not); unset: every model available that "
        "declares one (`lgmd_sim.calibration.search.detector_list`)")
    budget: int = setting(32, "candidate settings per detector, its starting preset "
                          "included (the same for every detector)")
    seeds: int = setting(8, "episode seeds per clip group in each set")
    first_seed: int = setting(0, "the first search seed")
    heldout_seed: int = setting(100, "the first held-out seed; the two sets must not overlap")
    seed: int = setting(0, "the seed of the random search")
    resolution: str | tuple[int, int] = setting(
        "rl", "frame size of the clips: rl (120x160, the closed-loop task's), paper, small "
        "or HxW")
    save_presets: bool = setting(
        False, "also merge the calibrated presets into your presets file, calibrated.json "
        "in $LGMD_SIM_DATA_DIR (else the user data folder, ~/.local/share/lgmd-sim on "
        "Linux): only the calibrated detectors' presets change there, and the models read "
        "it on top of the shipped presets")
    presets_file: str | Path | None = setting(
        None, "merge them into this file instead (implies save_presets); never one inside "
        "the installed package; the models read only your presets file, so a file named "
        "calibrated.json serves them once LGMD_SIM_DATA_DIR names its folder. Either "
        "target is checked when the configuration is made: a presets file or none, that "
        "can be written, in a folder that can be written or made "
        "(`lgmd_sim.models.presets.check_target`)")

    def __post_init__(self) -> None:
        checked("task", self.task, one_of(*TASKS))
        task = TASKS[self.task]
        fronts = (task.front,) if task.front else (None, *task.fronts)
        detectors = detector_list(self.detectors, fronts)
        for i, d in enumerate(detectors):
            front = space(d).front
            if task.front and front is None:  # the task's own, given or not
                detectors[i], front = f"{d}+{task.front}", task.front
            if front is not None and front not in task.fronts:
                raise ValueError(f"detector {d!r}: the {self.task} task's front ends are "
                                 f"{', '.join('+' + f for f in task.fronts)}")
        object.__setattr__(self, "detectors", tuple(detectors))
        checked("budget", self.budget, count)
        checked("seeds", self.seeds, count)
        for name in ("first_seed", "heldout_seed", "seed"):
            checked(name, getattr(self, name), seed)
        if set(self.search_seeds) & set(self.heldout_seeds):
            raise ValueError("the search and held-out seeds overlap: move heldout_seed")
        object.__setattr__(self, "resolution", options.resolution(self.resolution))
        target = self.presets_target
        if target is not None:
            if target.resolve().is_relative_to(presets.PACKAGE):
                raise ValueError(f"presets file {target}: inside the installed package; the "
                                 "shipped presets change only by "
                                 "docs/experiments/tools/ship_presets.py in a checkout")
            # a file it cannot merge into fails now, not after the whole calibration
            presets.check_target(target)

    @property
    def presets_target(self) -> Path | None:
        """The presets file the calibrated presets are merged into, None: none."""
        if self.presets_file is not None:
            return Path(self.presets_file)
        return presets.user_presets_file() if self.save_presets else None

    @property
    def search_seeds(self) -> list[int]:
        return list(range(self.first_seed, self.first_seed + self.seeds))

    @property
    def heldout_seeds(self) -> list[int]:
        return list(range(self.heldout_seed, self.heldout_seed + self.seeds))

    def as_json(self) -> dict[str, Any]:
        """The configuration as the run folder records it (what identifies the run)."""
        task = TASKS[self.task]
        return {"calibration": 1, "task": self.task, "cruise": task.cruise,
                "detectors": list(self.detectors),
                "budget": self.budget, "search_seeds": [self.first_seed, self.seeds],
                "heldout_seeds": [self.heldout_seed, self.seeds],
                "resolution": self.resolution, "groups": task.groups,
                **task.objective.identity(), **task.identity(), "seed": self.seed}


#: What the search reads of a clip's record and of a candidate's (its scores as the task's
#: objective keeps them): one holding less is refused on resuming.
CLIP_FIELDS = {"key": str, "kind": str, "frames": int, "collision_frame": (int, NULL)}


def _candidate_fields(objective: Objective) -> Fields:
    return {"detector": str, "index": int, "params": dict,
            "sets": {"search": objective.fields, "heldout": objective.fields}}


def choose(records: Sequence[dict[str, Any]], clip_sets: dict[str, list[dict]],
           objective: Objective = WALKER) -> dict[str, Any]:
    """The best candidate and threshold of one detector on the search set, and how it
    does on both sets."""
    kinds = {s: np.array([r["kind"] for r in recs]) for s, recs in clip_sets.items()}
    best = None
    for rec in records:
        score, _ = objective.value(kinds["search"], rec["sets"]["search"], slice(None))
        i = int(np.argmax(score))  # the lowest threshold among equals
        if best is None or score[i] > best[0]:
            best = (float(score[i]), rec, i)
    _, rec, i = best
    result = {"detector": rec["detector"], "candidate": rec["index"],
              "params": rec["params"], "threshold": float(THRESHOLDS[i])}
    for set_name in clip_sets:
        score, rates = objective.value(kinds[set_name], rec["sets"][set_name],
                                       slice(i, i + 1))
        result[set_name] = {"objective": float(score[0]),
                            **{k: float(v[0]) for k, v in rates.items()}}
    return result


def calibrate(config: CalibrateConfig, out: str | Path, options: RunOptions = RunOptions()
              ) -> RunResult:
    """Run (or resume) the calibration of `config` in folder `out` (the arguments as
    `lgmd_sim.benchmark.closed_loop.run`'s); return one row per detector: the chosen
    candidate and threshold, with its scores on the search and held-out sets."""
    from lgmd_sim.models.check import preflight

    task = TASKS[config.task]
    objective = task.objective
    preflight((s.model, f"{s.preset}+{s.front}" if s.front else s.preset)
              for s in map(space, config.detectors))
    folder = RunFolder(out, config.as_json(), options.command, resume=options.resume)
    clip_dir = folder.path / "clips"
    clip_dir.mkdir(exist_ok=True)
    sets = {"search": clip_mod.specs(task.groups, config.search_seeds),
            "heldout": clip_mod.specs(task.groups, config.heldout_seeds),
            **{name: clip_mod.specs(task.groups, config.heldout_seeds, name)
               for name in task.looks if name}}
    all_specs = [s for specs in sets.values() for s in specs]
    done = folder.done()
    jobs = [Job(f"clip-{s.key}", clip_mod.record_clip,
                {"spec": s, "folder": str(clip_dir), "resolution": config.resolution,
                 "cruise": task.cruise, "fronts": task.fronts,
                 "looks": task.looks[s.looks], "fovy": task.fovy})
            for s in all_specs if f"clip-{s.key}" not in done]
    run_jobs(jobs, lambda job, rec: folder.store(job.key, {**rec, "key": job.key[5:]}),
             options, desc="recording clips", unit="clip")
    clip_sets = {name: folder.records([f"clip-{s.key}" for s in specs], CLIP_FIELDS)
                 for name, specs in sets.items()}
    cands = [c for d in config.detectors for c in candidates(d, config.budget, config.seed)]
    jobs = [Job(c.key, evaluate, {"candidate": c, "folder": str(clip_dir),
                                  "clip_sets": clip_sets, "objective": objective})
            for c in cands if c.key not in done]
    run_jobs(jobs, lambda job, rec: folder.store(job.key, rec), options, desc="candidates",
             unit="candidate")
    chosen = [choose(folder.records([c.key for c in cands if c.detector == d],
                                    _candidate_fields(objective)), clip_sets, objective)
              for d in config.detectors]
    write_text_atomic(folder.path / "summary.md", summary_markdown(chosen, objective))
    fig = calibration_figure(chosen, objective)
    text = png_text(options.command or None, {"run": folder.path.name})
    write_files({folder.path / "calibration.png":
                 lambda tmp: fig.savefig(tmp, format="png", dpi=110, metadata=text)})
    calibration = {
        "command": options.command, "objective": objective.text,
        "search_seeds": [config.first_seed, config.seeds],
        "heldout_seeds": [config.heldout_seed, config.seeds],
        "resolution": folder.config["resolution"], "budget": config.budget,
        "figure": "calibration.png",
        "presets": {preset_name(c["detector"])[0]: {} for c in chosen},
    }
    for c in chosen:
        model, name = preset_name(c["detector"], config.task)
        sp = space(c["detector"])
        params = {**c["params"], "threshold": c["threshold"],
                  **task.preset_params(sp.front, config.resolution)}
        calibration["presets"][model][name] = {"from": sp.preset, "params": params,
                                               **{n: c[n] for n in _sets(chosen)}}
    write_text_atomic(folder.path / "calibrated.json", json.dumps(calibration, indent=2) + "\n")
    files = ["summary.md", "calibration.png", "calibrated.json", "run.json"]
    target = config.presets_target
    if target is not None:
        presets.merge_presets(target, calibration)
        files.append(str(target))
    folder.finish(candidates=len(cands), clips=len(all_specs))
    return RunResult(folder.path, chosen, files)
