"""calibration.png drawn again from what a calibration left: a finished run's folder, or
the presets one ``lgmd-sim calibrate`` command merged into a presets file (`chosen_of`,
`redraw`).

Apart from the job (`lgmd_sim.calibration.run`): it reads a calibration back, and runs
none; docs/experiments/tools/calibration_figure.py draws the docs' figures with it.
"""

from __future__ import annotations

import json
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from lgmd_sim.calibration.objective import Objective
from lgmd_sim.calibration.report import calibration_figure
from lgmd_sim.calibration.run import CalibrateConfig
from lgmd_sim.calibration.tasks import TASKS, preset_name
from lgmd_sim.core.fileio import write_files
from lgmd_sim.core.pngtext import png_text

__all__ = ["chosen_of", "redraw"]


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
