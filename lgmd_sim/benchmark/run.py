"""One entry through every track of a protocol: `benchmark` runs the closed-loop tracks
with the closed-loop bench (`lgmd_sim.benchmark.closed_loop`), the open-loop tracks clip by
clip, and writes the entry's ``result.json``: its scores with intervals, the raw metrics
and the per-seed parts the leaderboard compares entries by.

Layout of an entry's folder (``OUT/<entry>``): ``goal/`` and ``arena/`` (closed-loop
bench run folders: their episodes and tables, no figures), ``detection/`` and, in protocol
2, ``stimuli/`` (run folders of one record per clip), ``result.json`` and
``episodes.json`` (`EPISODES`); a calibrated entry's ``calibration/`` and `PRESETS`. Every
part keeps its finished jobs: running the same command again completes an interrupted
benchmark.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from lgmd_sim import __version__
from lgmd_sim.benchmark import camera, detection, scores
from lgmd_sim.benchmark.entries import Entry
from lgmd_sim.benchmark.protocol import CameraTrack, ClosedLoopTrack, DetectionTrack, Protocol
from lgmd_sim.core.fileio import canonical_json, write_text_atomic
from lgmd_sim.core.machine import machine
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.core.runs import RunFolder

__all__ = ["EPISODES", "PRESETS", "RESULT", "benchmark", "calibrated", "check_entries",
           "episode_score", "track_config"]

#: An entry's result, in its folder.
RESULT = "result.json"
#: Its closed-loop episodes' records without their drawings, by track: what `lgmd-sim
#: verify` replays a published row against (the run folders' records/ stay where it ran).
EPISODES = "episodes.json"
#: What `EPISODES` leaves out of a record: the top view, drawn for the first seeds.
UNPUBLISHED = ("top_view",)
#: A calibrated entry's presets file, in its folder: the preset its calibration made, which
#: its episodes read in place of the user's presets (`calibrated`).
PRESETS = Path("presets", "calibrated.json")
#: What `calibrated` adds to the preset a built-in's calibration makes, whose name the
#: model ships already.
RECALIBRATED = "recalibrated"
#: What a result keeps of each closed-loop track's summary rows, per jitter level.
_COLUMNS = {
    "goal": ("episodes", "success_rate", "success_ci", "collision_rate", "collision_ci",
             "false_alarms_per_min", "mean_progress", "mean_time_s"),
    "arena": ("episodes", "avoidance_rate", "avoidance_ci", "encounters",
              "collisions_per_min", "false_alarms_per_min", "mean_distance_m"),
}


def track_config(entry: Entry, protocol: Protocol, track: ClosedLoopTrack) -> Any:
    """The closed-loop bench's configuration (`lgmd_sim.benchmark.closed_loop.ClosedLoopConfig`)
    of the entry's cells in `track`: its scenario, jitter levels and seeds, at the
    protocol's frame size, cruise and horizon."""
    from lgmd_sim.benchmark import closed_loop

    return closed_loop.ClosedLoopConfig(
        scenarios=(track.scenario,), jitter=track.jitter,
        **entry.bench_options(track.scenario, track.jitter), seeds=track.episodes,
        first_seed=track.first_seed, resolution=protocol.resolution, cruise=protocol.cruise,
        horizon=protocol.horizon)


def _clip_track(entry: Entry, protocol: Protocol, name: str, out: Path,
                jobs: Mapping[str, tuple[Callable[..., dict[str, Any]], dict[str, Any]]],
                options: RunOptions) -> list[dict[str, Any]]:
    """Run an open-loop track's clips through the entry's detector (a run folder in `out`,
    `jobs`: record name -> (job function, its arguments)); one record per clip."""
    from lgmd_sim.core.jobs import Job
    from lgmd_sim.core.parallel import run_jobs
    from lgmd_sim.models.presets import carrying_presets

    config = {name: protocol.identity(), "model": entry.model, "preset": entry.preset,
              "detector_params": entry.to_json()["params"]}
    folder = RunFolder(out, config, options.command, resume=True,
                       what=f"benchmark {name} track")
    done = folder.done()
    run_jobs([Job(k, carrying_presets(fn), {**args, "model": entry.model,
                                            "preset": entry.preset,
                                            "resolution": protocol.resolution})
              for k, (fn, args) in jobs.items() if k not in done],
             lambda job, record: folder.store(job.key, record), options,
             desc=f"{entry.label}: {name}", unit="clip")
    records = folder.records(list(jobs))
    folder.finish(clips=len(records))
    return records


def _stimuli(entry: Entry, protocol: Protocol, track: DetectionTrack, name: str, out: Path,
             options: RunOptions) -> list[dict[str, Any]]:
    """The synthetic clips' track (`lgmd_sim.benchmark.detection`): version 1's detection,
    version 2's stimuli."""
    approaching = set(track.approaching)
    jobs = {detection.key(c): (detection.clip_job, {
        "clip": c, "approaching": c[0] in approaching, "window_s": track.window_s})
        for c in detection.clips(track)}
    return _clip_track(entry, protocol, name, out, jobs, options)


def _camera(entry: Entry, protocol: Protocol, track: CameraTrack, out: Path,
            options: RunOptions) -> list[dict[str, Any]]:
    """The robot camera's detection track (`lgmd_sim.benchmark.camera`)."""
    window = (track.window_s[0], track.window_s[1])
    jobs = {camera.key(c): (camera.clip_job, {
        "clip": c, "cruise": track.cruise_of(c[3]), "window_s": window,
        "horizon": protocol.horizon}) for c in camera.clips(track)}
    return _clip_track(entry, protocol, "detection", out, jobs, options)


def _rows(records: list[dict[str, Any]], rows: list[dict[str, Any]], columns: tuple[str, ...],
          score: Callable[[Mapping[str, Any]], float]) -> dict[str, dict[str, Any]]:
    """Per jitter level: the `columns` of the bench's summary `rows` (one cell's, a row a
    level) and the track's score over its `records`."""
    out = {}
    for row in rows:
        level = [r for r in records if r["jitter"] == row["jitter"]]
        out[f"{row['jitter']:g}"] = {**{c: row.get(c) for c in columns},
                                     "score": sum(map(score, level)) / len(level)}
    return out


def check_entries(entries: Sequence[Entry], protocol: Protocol) -> None:
    """Refuse, before the first episode of any, entries that could not all run: two of one
    folder (two policies of the same folder name), a policy trained at another frame size
    than the protocol's, a plug-in detector that fails the preflight
    (`lgmd_sim.models.check.preflight`, which `benchmark` does not run again).

    Raises:
        ValueError: the first such entry, in one line naming it.
    """
    from lgmd_sim.models.check import preflight
    from lgmd_sim.policies import load_config
    from lgmd_sim.world.params import frame_size

    folders: dict[str, str] = {}
    for entry in entries:
        if entry.key in folders:
            raise ValueError(f"entries {folders[entry.key]!r} and {entry.spec!r} are both "
                             f"{entry.label!r}, one folder (OUT/{entry.key}): benchmark them "
                             "into two --out folders")
        folders[entry.key] = entry.spec
        if entry.kind == "policy":
            trained = load_config(entry.policy)[1].trained_frames()
            run = frame_size(protocol.resolution)
            if trained not in (None, run):
                raise ValueError(f"entry {entry.spec!r}: the policy was trained on "
                                 f"{trained[0]}x{trained[1]} frames, the protocol runs "
                                 f"{run[0]}x{run[1]} ({protocol.resolution})")
    preflight((e.model, e.preset) for e in entries if e.kind == "detector")


def episode_score(track: str, protocol: Protocol) -> Callable[[Mapping[str, Any]], float]:
    """The score of one episode's record of closed-loop `track` ("goal" or "arena": the
    latter weighs the distance by the protocol's reference at the episode's level)."""
    if track == "goal":
        return scores.goal_score
    reference = dict(zip(protocol.arena.jitter, protocol.arena.reference_distance_m,
                         strict=True))
    return lambda r: scores.arena_score(r, reference[r["jitter"]])


def _fingerprint(records: Sequence[Mapping[str, Any]]) -> str | None:
    """One digest over a track's episodes (`lgmd_sim.benchmark.fingerprint`), in their keys'
    order; None where an episode has none (recorded before fingerprints were)."""
    from lgmd_sim.benchmark.fingerprint import combined

    if not all("fingerprint" in r for r in records):
        return None
    return combined([r["fingerprint"]["sha256"] for r in records])


def _episodes_json(episodes: Mapping[str, Sequence[Mapping[str, Any]]]) -> str:
    """`EPISODES`' text: a record a line (half the bytes of an indented file, and a diff
    names the episode), keys sorted, each track's in its records' order."""
    import json

    def line(record: Mapping[str, Any]) -> str:
        kept = {k: v for k, v in record.items() if k not in UNPUBLISHED}
        return json.dumps(kept, sort_keys=True, separators=(",", ":"), allow_nan=False)

    tracks = [f'"{t}": [\n' + ",\n".join(map(line, records)) + "\n]"
              for t, records in episodes.items()]
    return "{\n" + ",\n".join(tracks) + "\n}\n"


def calibrated(entry: Entry, protocol: Protocol, out: str | Path,
               options: RunOptions = RunOptions()) -> tuple[Entry, Path]:
    """Tune detector `entry` by the protocol's calibration rule (`lgmd-sim calibrate` with
    its task, budget and seeds, on the entry's front end); return the entry at the preset
    it made and the presets file that holds it, which its benchmark reads in place of the
    user's presets (`lgmd_sim.models.presets.user_presets_from`).

    Everything goes in the calibrated entry's folder: ``calibration/`` (the calibration's
    run folder) and `PRESETS`.
    """
    from lgmd_sim.calibration.run import CalibrateConfig, calibrate
    from lgmd_sim.calibration.tasks import preset_name
    from lgmd_sim.core.fileio import read_json
    from lgmd_sim.models.presets import merge_presets

    if entry.kind != "detector":
        raise ValueError(f"entry {entry.spec!r} is no detector: only a detector is "
                         "calibrated")
    # the robot task's front ends are rotations (image, imu): a +gain is not calibrated
    detector = "+".join([entry.model, *(f for f in entry.preset.split("+")[1:] if f != "gain")])
    rule = protocol.calibration
    model, made = preset_name(detector, rule.task)
    # a built-in's row must not take the name of a preset it ships ("lgmd1/robot"): two
    # rows of one name, with other parameters
    preset = f"{made}-{RECALIBRATED}" if made in shipped_presets(model) else made
    tuned = dataclasses.replace(entry, model=model, preset=preset)
    folder = Path(out) / tuned.key
    config = CalibrateConfig(task=rule.task, detectors=(detector,),
                             budget=rule.budget, seeds=rule.seeds, first_seed=rule.first_seed,
                             heldout_seed=rule.heldout_seed, resolution=protocol.resolution)
    calibrate(config, folder / "calibration", dataclasses.replace(options, resume=True))
    calibration = read_json(folder / "calibration" / "calibrated.json")
    calibration["presets"] = {model: {preset: calibration["presets"][model][made]}}
    merge_presets(folder / PRESETS, calibration)
    return tuned, folder / PRESETS


def shipped_presets(model: str) -> set[str]:
    """The names of the presets model `model` ships: its class's and the package's
    calibrated ones (not a user's)."""
    from lgmd_sim import models
    from lgmd_sim.models.presets import CALIBRATED, preset_files

    return set(models.model_class(model).presets) | {
        name for name, path in preset_files(model).items() if path == CALIBRATED}


def _wall_time(folder: Path) -> float:
    """The seconds every session of the entry's runs took (its calibration's included):
    the same when a finished benchmark is run again to rewrite its result."""
    from lgmd_sim.core.fileio import read_json

    return round(sum(float(s.get("wall_time_s") or 0.0)
                     for run in sorted(folder.glob("*/run.json"))
                     for s in read_json(run).get("sessions", [])), 1)


def benchmark(entry: Entry, protocol: Protocol, out: str | Path,
              options: RunOptions = RunOptions(), *, presets: Path | None = None
              ) -> dict[str, Any]:
    """Run (or complete) `entry` through every track of `protocol` in ``out/<entry.key>``
    and write its ``result.json``; return the result.

    A detector runs every track; a controller the closed-loop ones (it has no detector to
    run on clips), a policy the goal track (it observes the goal, which the arena has not).
    `options` as `lgmd_sim.benchmark.closed_loop.run` takes them; a row always resumes
    (its finished episodes are kept, whatever ``options.resume`` says). The entry is one
    `check_entries` passed: its detector's preflight is not run again.

    Args:
        presets: a calibrated entry's presets file (`calibrated`), which this process and
            the workers read in place of the user's presets
            (`lgmd_sim.models.presets.user_presets_from`).
    """
    from lgmd_sim.benchmark import closed_loop
    from lgmd_sim.models.presets import user_presets_from

    folder = Path(out) / entry.key
    folder.mkdir(parents=True, exist_ok=True)
    options = dataclasses.replace(options, resume=True)
    # version 2 keeps each jitter level's episodes apart: the dose-response, J50
    levels = protocol.goal.jitter if protocol.version >= 2 else None
    with user_presets_from(presets):
        episodes: dict[str, list[dict[str, Any]]] = {}
        parts: dict[str, scores.Parts] = {}
        metrics: dict[str, Any] = {}
        traces: dict[str, str | None] = {}
        # a policy observes the goal, which the arena has not
        for track in ("goal",) if entry.kind == "policy" else scores.CLOSED_LOOP:
            config = track_config(entry, protocol, getattr(protocol, track))
            # its tables, not figures that no page of the benchmark shows
            bench = closed_loop.run(config, folder / track, options, figures=False,
                                    preflighted=True)
            score = episode_score(track, protocol)
            episodes[track] = bench.records
            parts[track] = scores.parts_of(bench.records, score, levels)
            metrics[track] = _rows(bench.records, bench.rows, _COLUMNS[track], score)
            traces[track] = _fingerprint(bench.records)
        if entry.kind == "detector":
            if isinstance(protocol.detection, CameraTrack):
                clips = _camera(entry, protocol, protocol.detection, folder / "detection",
                                options)
                parts["detection"] = camera.parts(clips, protocol.detection.jitter)
                metrics["detection"] = camera.metrics(clips)
            else:
                clips = _stimuli(entry, protocol, protocol.detection, "detection",
                                 folder / "detection", options)
                parts["detection"] = scores.detection_parts(clips)
                metrics["detection"] = detection.metrics(clips)
            if protocol.stimuli is not None:
                clips = _stimuli(entry, protocol, protocol.stimuli, "stimuli", folder / "stimuli",
                                 options)
                parts["stimuli"] = scores.detection_parts(clips)
                metrics["stimuli"] = detection.metrics(clips)
        write_text_atomic(folder / EPISODES, _episodes_json(episodes))
        summary = scores.summarise(parts, protocol.bootstrap, protocol.bootstrap_seed)
        result = {"protocol": protocol.identity(), "entry": entry.to_json(),
                  "lgmd_sim": __version__, "machine": machine(), "command": options.command,
                  "scores": summary.scores, "intervals": summary.intervals, "metrics": metrics,
                  "parts": {t: p.to_json() for t, p in parts.items()},
                  "fingerprints": traces, "timing": {"wall_time_s": _wall_time(folder)}}
        write_text_atomic(folder / RESULT, canonical_json(result))
    return result
