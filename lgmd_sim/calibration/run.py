"""`lgmd-sim calibrate`: the same search for every model, judged on clips it never saw.

A task (`TASKS`) is the clips and the objective they are judged by: "walker" (a hand-held,
mutual or steady camera; `lgmd_sim.calibration.objective`), "robot" (the robot driving
at obstacles and past them; `lgmd_sim.calibration.robot`) or "video" (footage from a
camera nobody calibrated: the walker's clips and synthetic stimuli that do not loom, with
a real camera's noise, every detector with the front end a video allows, `VIDEO`).

1. Record the task's clips (`lgmd_sim.calibration.clips`): a search set and a held-out set
   with disjoint seeds, into ``DIR/clips``.
2. Evaluate every candidate of every detector (`lgmd_sim.calibration.search`): the same
   number of candidates each, one job each, records in ``DIR/records`` (resumable).
3. Per detector, choose the candidate and threshold with the best objective on the search
   set; report it on the held-out set beside.
4. Write ``DIR/summary.md``, ``DIR/calibration.png`` and ``DIR/calibrated.json``: the
   presets with the command, seeds, objective and figure that produced them. With
   ``save_presets`` also merge them into the user's presets file (or ``presets_file``:
   `lgmd_sim.models.presets`), which makes them the models' ``calibrated`` presets (and
   ``calibrated-open-loop`` for the feedback model's open-loop control, gain 0, tuned by
   the same search; the robot task's: ``robot``, ``robot-open-loop``) on top of the
   shipped ones; the other presets there stay.
"""

from __future__ import annotations

import dataclasses
import json
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim.calibration import clips as clip_mod
from lgmd_sim.calibration.objective import VIDEO, WALKER, Objective
from lgmd_sim.calibration.robot import ROBOT, ROBOT_FRAMES
from lgmd_sim.calibration.search import (
    CONTROLS,
    THRESHOLDS,
    candidates,
    detector_list,
    evaluate,
    space,
)
from lgmd_sim.controllers import options
from lgmd_sim.core.fileio import write_files, write_text_atomic
from lgmd_sim.core.parallel import Job, RunOptions, run_jobs
from lgmd_sim.core.pngtext import png_text
from lgmd_sim.core.runs import NULL, Fields, RunFolder, RunResult
from lgmd_sim.envs.zone import CRUISE
from lgmd_sim.models import presets
from lgmd_sim.signals.metrics import PAPER_ALARM
from lgmd_sim.world.params import frame_size

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["TASKS", "CalibrateConfig", "Task", "calibrate", "calibration_figure", "choose",
           "chosen_of", "preset_name", "redraw", "summary_markdown"]


@dataclass(frozen=True)
class Task:
    """What a calibration is about: its clips, the objective that judges them, and the
    name its presets start with.

    Attributes:
        objective, groups (as `lgmd_sim.calibration.clips.DEFAULT_GROUPS`), prefix.
        cruise: the forward action the clips are driven at (None: Straight's).
        fronts: the front ends its clips keep the motions of, which its detectors may have.
        front: None, or the front end every detector has (given or not), which its presets'
            names leave out: the presets are the front end and the model together.
        looks: the families of looks its clips are recorded in
            (`lgmd_sim.calibration.clips.Looks`): "" the search and held-out sets', and
            each other a set of its own, of the held-out seeds (a transfer check).
        fovy: None, or the vertical field of view (degrees) the front end assumes, with the
            scenes' cameras drawn around it (`lgmd_sim.calibration.clips.record_clip`).
        at_clip_size: the presets shrink every frame to the clips' height
            (``working_height``), so that they see a video of any size as they saw the
            clips: a model's kernels and thresholds are in pixels.
    """

    objective: Objective
    groups: Mapping[str, list[tuple[str, tuple[float, ...]]]]
    prefix: str
    cruise: float | None = None
    fronts: tuple[str, ...] = ("image", "imu")
    front: str | None = None
    looks: Mapping[str, clip_mod.Looks] = field(
        default_factory=lambda: {"": clip_mod.Looks()})
    fovy: float | None = None
    at_clip_size: bool = False

    def identity(self) -> dict[str, Any]:
        """What a run folder records of the task beyond its groups and objective."""
        return {"looks": {name: dataclasses.asdict(v) for name, v in self.looks.items()},
                "fovy": self.fovy}

    def preset_params(self, front: str | None, resolution: str | Sequence[int]
                      ) -> dict[str, Any]:
        """The model parameters this task fixes in its presets, beside the searched ones
        and the threshold: front end `front`'s, the clips' height (`at_clip_size`, clips
        of `resolution`) and the objective's alarm rule where it is not the paper's."""
        out: dict[str, Any] = {}
        if front is not None:
            stabilize, _, gain = front.partition("+")
            out.update(stabilize=stabilize, **({"gain": True} if gain else {}),
                       **({"fovy": self.fovy} if self.fovy else {}))
        if self.at_clip_size:
            out["working_height"] = frame_size(resolution)[0]
        if self.objective.alarm != PAPER_ALARM:
            out.update(alarm_frames=self.objective.alarm.frames,
                       alarm_rising=self.objective.alarm.rising)
        return out


#: The calibration tasks: the walker's clips (today's calibrated presets), the robot's,
#: driven at the closed-loop benchmark's cruise, and the video task's.
TASKS: dict[str, Task] = {
    "walker": Task(WALKER, clip_mod.DEFAULT_GROUPS, "calibrated"),
    "robot": Task(ROBOT, clip_mod.ROBOT_GROUPS, "robot", CRUISE),
    "robot-frames": Task(ROBOT_FRAMES, clip_mod.ROBOT_GROUPS, "robot-frames",
                         CRUISE),
    "video": Task(VIDEO, clip_mod.VIDEO_GROUPS, "video", fronts=("image+gain",),
                  front="image+gain", looks=clip_mod.VIDEO_LOOKS, fovy=clip_mod.VIDEO_FOVY,
                  at_clip_size=True),
}


@dataclass(frozen=True)
class CalibrateConfig:
    """What `calibrate` runs, checked when it is made (a bad value raises a one-line
    ValueError naming it).

    Attributes:
        task: a key of `TASKS`: the clips and the objective ("walker", "robot" or
            "video").
        detectors: detectors of `lgmd_sim.calibration.search.space`: a model whose class
            declares a search space (a name, or a plug-in's "package.module:Class" spec),
            or the feedback LGMD's open-loop control "feedback-open-loop", each also with
            a front end of the task's ("lgmd1+image"; in a task with a front end of its
            own, that one, given or not); None: every one of the models available
            (`lgmd_sim.calibration.search.detector_list`).
        budget: candidate settings per detector, its starting preset included (the same
            for every detector).
        seeds: episode seeds per clip group in each set.
        first_seed: the first search seed.
        heldout_seed: the first held-out seed; the two sets must not overlap.
        seed: the seed of the random search.
        resolution: the clips' frame size.
        save_presets: also merge the presets into the user's presets file
            (`lgmd_sim.models.presets.user_presets_file`).
        presets_file: merge them into this file instead (implies ``save_presets``); never
            one inside the installed package. Either target is checked when the
            configuration is made: a presets file or none, that can be written, in a folder
            that can be written or made (`lgmd_sim.models.presets.check_target`).
    """

    task: str = "walker"
    detectors: tuple[str, ...] | None = None
    budget: int = 32
    seeds: int = 8
    first_seed: int = 0
    heldout_seed: int = 100
    seed: int = 0
    resolution: str | tuple[int, int] = "rl"
    save_presets: bool = False
    presets_file: str | Path | None = None

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise ValueError(f"--task {self.task!r}: must be one of {', '.join(TASKS)}")
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
        options.check_positive(self.budget, "--budget", integer=True)
        options.check_positive(self.seeds, "--seeds", integer=True)
        for name in ("first_seed", "heldout_seed", "seed"):
            options.check_seed(getattr(self, name), f"--{name.replace('_', '-')}")
        if set(self.search_seeds) & set(self.heldout_seeds):
            raise ValueError("the search and held-out seeds overlap: move --heldout-seed")
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


def preset_name(detector: str, task: str = "walker") -> tuple[str, str]:
    """The (model, preset) a calibrated detector becomes: the task's prefix ("calibrated",
    "robot", "video"), for the feedback LGMD's control "calibrated-open-loop", with a
    front end "calibrated-image", "robot-open-loop-imu" ... (not the task's own front end:
    "video")."""
    sp = space(detector)
    name = TASKS[task].prefix + ("-open-loop" if detector.partition("+")[0] in CONTROLS
                                 else "")
    return sp.model, name + (f"-{sp.front}" if sp.front and sp.front != TASKS[task].front
                             else "")


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


def _sets(chosen: Sequence[dict[str, Any]]) -> list[str]:
    """The clip sets the chosen candidates were scored on, in order: search, held-out,
    then any transfer set (`choose` keeps them in the order of its clip sets)."""
    return [k for k, v in chosen[0].items() if isinstance(v, dict) and "objective" in v]


def _set_label(name: str) -> str:
    return {"heldout": "held-out"}.get(name, name)


def summary_markdown(chosen: Sequence[dict[str, Any]], objective: Objective = WALKER) -> str:
    """The chosen candidates, search and held-out (and transfer, where there is one), as
    a Markdown table: the objective and each of its parts ("-" for a part the clips lack,
    which the objective leaves out)."""
    sets = _sets(chosen)
    lines = [f"| detector | threshold | objective {' / '.join(map(_set_label, sets))} | "
             + " | ".join(objective.parts.values()) + " |",
             "|---|---:|---:|" + "---:|" * len(objective.parts)]
    for c in chosen:
        cells = [" / ".join(f"{c[n][k]:.2f}" for n in sets) if k in c["search"] else "-"
                 for k in objective.parts]
        score = " / ".join(f"{c[n]['objective']:.3f}" for n in sets)
        lines.append(f"| {c['detector']} | {c['threshold']:.3f} | {score} | "
                     f"{' | '.join(cells)} |")
    return "\n".join(lines) + "\n"


#: Inches: what each detector's pair of bars takes in a panel, and the least a panel is
#: wide, so that its title and the legend fit with a single detector.
_PER_DETECTOR, _MIN_PANEL = 0.6, 3.4
#: The y axis of calibration.png: the objective and each part, a share of clips (frames
#: for the robot's balanced accuracy) that went as the panel's title says.
SCORE_LABEL = "score (0 to 1, 1 best)"


def calibration_figure(chosen: Sequence[dict[str, Any]], objective: Objective = WALKER
                       ) -> Figure:
    """calibration.png: for the objective and each of its parts, each chosen detector's
    score on the search and the held-out seeds (and the transfer set, where there is
    one)."""
    from matplotlib.patches import Patch

    from lgmd_sim.core.plots import figure, model_style

    names = [c["detector"] for c in chosen]
    panels = ("objective", *objective.parts)
    cols = -(-len(panels) // 2)  # two rows
    fig = figure(figsize=(cols * max(_MIN_PANEL, _PER_DETECTOR * len(names)) + 0.8, 9.0))
    axes = fig.subplots(2, cols, sharey=True).ravel()
    for ax in axes[len(panels):]:
        ax.axis("off")
    x = np.arange(len(names))
    colours = [model_style(n.split("-")[0])["color"] for n in names]
    bar = {"edgecolor": "black", "lw": 0.5}
    sets = _sets(chosen)
    alphas = dict(zip(sets, (1.0, 0.45, 0.2), strict=False))
    width = 0.76 / len(sets)
    for ax, what in zip(axes, panels, strict=False):
        for k, set_name in enumerate(sets):
            # a part the clips lack has no bar
            bars = ax.bar(x + (k - (len(sets) - 1) / 2) * width,
                          [c[set_name].get(what, np.nan) for c in chosen],
                          width, color=colours, alpha=alphas[set_name], **bar)
            for b, n in zip(bars, names, strict=True):
                if "open-loop" in n:  # the feedback LGMD's control: its colour, hatched
                    b.set_hatch("//")
        ax.set_xticks(x, names, rotation=45, ha="right", fontsize="small")
        ax.set_xlim(-0.7, len(names) - 0.3)  # a lone detector's bars keep their width
        ax.set_title(objective.titles[what], fontsize="medium")
        ax.set_ylim(0, 1.02)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes[::cols]:  # the first of each row (the others share its y axis)
        ax.set_ylabel(SCORE_LABEL)
    # the key in grey: the bars' colours are the detectors', named below each pair
    handles = [Patch(facecolor="0.4", alpha=alphas[n], label=f"{_set_label(n)} seeds"
                     if n in ("search", "heldout") else f"{n}: held-out seeds in other looks",
                     **bar) for n in sets]
    if any("open-loop" in n for n in names):
        handles.append(Patch(facecolor="white", hatch="//",
                             label="the feedback LGMD's open-loop control", **bar))
    fig.legend(handles=handles, loc="outside upper center", ncols=len(handles),
               fontsize="small", title="bars in each detector's colour",
               title_fontsize="small")
    return fig


def _calibration_of(command: str) -> CalibrateConfig:
    """The task and detectors of a recorded `lgmd-sim calibrate` command line (as
    `lgmd_sim.cli.command_line` writes it, a PYTHONPATH before it or not), as the
    configuration it ran: read from its words, not by the command line's parser (a job
    does not import the commands)."""
    words = shlex.split(command)
    if "calibrate" not in words:
        raise ValueError(f"not an lgmd-sim calibrate command: {command!r}")

    def option(name: str) -> str | None:
        for i, word in enumerate(words):
            if word == name and i + 1 < len(words):
                return words[i + 1]
            if word.startswith(f"{name}="):
                return word.partition("=")[2]
        return None

    detectors = option("--detectors")
    return CalibrateConfig(task=option("--task") or "walker",
                           detectors=None if detectors in (None, "all")
                           else tuple(detectors.split(",")))


def _calibrations(presets_file: Path) -> dict[str, dict[str, dict[str, Any]]]:
    """The presets of a presets file grouped by the command of the calibration that made
    each: command -> {model: {preset: entry}} (a preset without a record of its own, as
    in a run's calibrated.json, made by the file's)."""
    data = json.loads(presets_file.read_text())
    out: dict[str, dict[str, Any]] = {}
    for model, entries in data["presets"].items():
        for name, entry in entries.items():
            command = entry.get("calibration", data).get("command")
            if command:
                out.setdefault(command, {}).setdefault(model, {})[name] = entry
    return out


def _source(source: Path, task: str | None
            ) -> tuple[Sequence[str], str, Mapping[str, Any], dict[str, Any]]:
    """What `chosen_of` reads of `source`: the calibration's detectors, its task, its
    presets (model -> {preset: entry}) and what identifies it (what a figure records)."""
    if source.is_dir():
        config = json.loads((source / "run.json").read_text())["config"]
        run_task = config.get("task", "walker")
        if task not in (None, run_task):
            raise ValueError(f"{source}: a calibration of the {run_task} task, not {task}")
        presets_of = json.loads((source / "calibrated.json").read_text())["presets"]
        return config["detectors"], run_task, presets_of, {"run": source.name}
    if task is None:
        raise ValueError(f"{source}: a presets file: name the calibration's task")
    found: dict[str, tuple[Sequence[str], Mapping[str, Any]]] = {}
    for command, presets_of in _calibrations(source).items():
        config = _calibration_of(command)
        if config.task == task:
            found[command] = (config.detectors, presets_of)
    if not found:
        raise ValueError(f"{source}: holds no calibration of the {task} task")
    if len(found) > 1:  # a file several merged into: --task names none alone
        raise ValueError(f"{source}: {len(found)} calibrations of the {task} task, not one:"
                         + "".join(f"\n  {c}" for c in found))
    ((command, (detectors, presets_of)),) = found.items()
    return detectors, task, presets_of, {"presets": source.name, "calibration": command}


def _chosen(detectors: Sequence[str], task: str, presets_of: Mapping[str, Any],
            source: Path) -> list[dict[str, Any]]:
    chosen = []
    for detector in detectors:
        model, name = preset_name(detector, task)
        entry = presets_of.get(model, {}).get(name)
        if entry is None:
            raise ValueError(f"{source}: no preset {model}/{name} of this calibration "
                             f"(detector {detector})")
        # a set's scores hold a number as their objective; a presets file's provenance
        # ("calibration") holds the objective's text
        chosen.append({"detector": detector, "threshold": entry["params"]["threshold"],
                       **{k: v for k, v in entry.items() if isinstance(v, dict)
                          and isinstance(v.get("objective"), (int, float))}})
    return chosen


def chosen_of(source: str | Path, task: str | None = None
              ) -> tuple[list[dict[str, Any]], Objective]:
    """The chosen candidates' scores of a calibration, as `calibrate` chose them, in the
    order of its detectors, and its task's objective: what `calibration_figure` draws.

    `source`: a finished run's folder (its run.json and calibrated.json, what a docs folder
    keeps of a run), or a presets file (the shipped `lgmd_sim.models.presets.CALIBRATED`)
    with the `task` of the calibration to take: the presets that one ``lgmd-sim
    calibrate`` command of that task made (each preset records its command), in the order
    of its ``--detectors``.

    Raises:
        ValueError: the file holds no calibration of `task`, or several, or lacks one of
            its detectors' presets; a `task` given with a run of another task.
    """
    source = Path(source)
    detectors, task, presets_of, _ = _source(source, task)
    return _chosen(detectors, task, presets_of, source), TASKS[task].objective


def redraw(source: str | Path, out: str | Path | None = None, command: str | None = None,
           task: str | None = None) -> Path:
    """calibration.png of a calibration drawn again from what `chosen_of` reads of
    `source` (a run folder, or a presets file and the calibration's `task`), into `out`
    (None: the run folder's own; a presets file has none), recording the `command` that
    drew it and which calibration (`lgmd_sim.core.pngtext`); returns where."""
    source = Path(source)
    detectors, task, presets_of, identity = _source(source, task)
    if out is None:
        if "run" not in identity:
            raise ValueError(f"{source}: a presets file keeps no figure: give out")
        out = source / "calibration.png"
    fig = calibration_figure(_chosen(detectors, task, presets_of, source), TASKS[task].objective)
    text = png_text(command, identity)
    write_files({Path(out): lambda tmp: fig.savefig(tmp, format="png", dpi=110,
                                                    metadata=text)})
    return Path(out)


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
