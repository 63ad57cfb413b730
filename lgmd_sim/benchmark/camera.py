"""The detection track of protocol 2: a detector alone on the robot's own camera, no
controller. Every clip is an episode of a robot scenario recorded in the world as the
robot calibration records its clips (`lgmd_sim.calibration.clips.HoldLine`: straight along
the scenario's line over rough ground): driving at a box or a wall until it hits it
(approach), or past obstacles and angled walls and over open ground (clear), at each
jitter level and at the forward speeds of the protocol's ``cruise`` list, one a seed in
turn. Every frame is labelled by the world's ground truth of its threat
(`lgmd_sim.calibration.robot.frame_label`): a **window** frame when the threat ahead is
within the protocol's window of times to collision (the times at which the reference
manoeuvre, started then, avoids it: the Oracle's measured window), a **clear** frame when
no threat is within the horizon.

The score is the mean of four rates, each jitter level alike: approach clips whose first
alarm falls in the window (earlier is a false alarm, later a miss), clear clips with no
alarm, window frames alarmed and clear frames silent. The robot acts on its first alarm
and on every later one; the rates say how often each is right. Beside it: false alarms
per minute (alarm onsets on clear frames), the lead time of the hits and the ROC AUC of
the potential, window frames against clear ones.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lgmd_sim.benchmark.protocol import CameraTrack
from lgmd_sim.benchmark.scores import Parts

__all__ = ["RATES", "CameraClip", "clip_job", "clips", "metrics", "parts"]

#: A clip of the track: (kind, scenario, jitter level, seed).
CameraClip = tuple[str, str, float, int]
#: The four rates of the score, in the order of each level's pairs in the parts.
RATES = ("approach_hit", "clear_silent", "window_alarmed", "clear_frames_silent")


def clips(track: CameraTrack) -> list[CameraClip]:
    """Every clip of the track, approach clips first."""
    kinds = [("approach", s) for s in track.approaching] + [("clear", s) for s in track.clear]
    return [(kind, scenario, j, seed) for kind, scenario in kinds for j in track.jitter
            for seed in track.seeds]


def key(clip: CameraClip) -> str:
    """A clip's record name."""
    _, scenario, jitter, seed = clip
    return f"{scenario}-j{jitter:g}-s{seed}"


def clip_job(clip: CameraClip, model: str, preset: str, resolution: Any, cruise: float,
             window_s: tuple[float, float], horizon: float) -> dict[str, Any]:
    """Record one clip driving at forward action `cruise` and run detector (`model`,
    `preset`) on it, frame by frame as the reference controller does (a pose- or
    IMU-stabilised front end reads its rotation from the frame's ground truth); judge its
    alarms against the labels (a job: runs in a worker)."""
    from lgmd_sim import models
    from lgmd_sim.calibration.clips import HoldLine
    from lgmd_sim.calibration.robot import frame_label
    from lgmd_sim.controllers import rollout
    from lgmd_sim.envs.reuse import episode_env
    from lgmd_sim.envs.wrappers.frames import check_frame_space
    from lgmd_sim.signals.metrics import alarm_onsets

    kind, scenario, jitter, seed = clip
    detector = models.make(model, preset=preset)
    potentials, alarms, ttc, bearing = [], [], [], []
    with episode_env(scenario, jitter=jitter, resolution=resolution) as env:
        check_frame_space(env.observation_space)
        fps = float(env.unwrapped.params.fps)
        for step in rollout(env, HoldLine(cruise=cruise), seed=seed):
            out = detector.step(step.obs["frame"], rotation=detector.rotation_from(step.info))
            potentials.append(float(out.potential))
            alarms.append(bool(out.alarm))
            ttc.append(float(step.info["threat_ttc"]))
            bearing.append(float(step.info["threat_bearing"]))
    label = frame_label(kind, np.array(ttc), np.array(bearing), window_s, horizon)
    alarm = np.array(alarms)
    first = int(alarm.argmax()) if alarm.any() else None
    if kind == "clear":
        outcome = "silent" if first is None else "false_alarm"
    elif first is None:
        outcome = "miss"
    elif label.window[first]:
        outcome = "hit"
    else:  # before the window the robot turns away from nothing; after it, too late
        outcome = "late" if label.window[:first].any() else "early"
    onsets = alarm_onsets(alarm)
    return {"kind": kind, "scenario": scenario, "jitter": jitter, "seed": seed,
            "cruise": cruise, "frames": len(alarms), "fps": fps, "first_alarm": first,
            "outcome": outcome,
            "lead_s": ttc[first] if outcome == "hit" else None,
            "window_frames": int(label.window.sum()),
            "window_alarmed": int((alarm & label.window).sum()),
            "clear_frames": int(label.clear.sum()),
            "clear_silent": int((~alarm & label.clear).sum()),
            "clear_onsets": int(label.clear[onsets].sum()),
            "potentials": potentials, "window": label.window.tolist(),
            "clear": label.clear.tolist()}


def parts(records: Sequence[Mapping[str, Any]], levels: Sequence[float]) -> Parts:
    """The track's parts: per seed and jitter level, the four `RATES`' (numerator,
    denominator) pairs over that seed's clips of the level."""
    seeds = tuple(sorted({int(r["seed"]) for r in records}))
    row = {s: i for i, s in enumerate(seeds)}
    col = {float(j): k for k, j in enumerate(levels)}
    sums = np.zeros((len(seeds), len(levels), len(RATES), 2))
    for r in records:
        cell = sums[row[int(r["seed"])], col[float(r["jitter"])]]
        if r["kind"] == "approach":
            cell[0] += (r["outcome"] == "hit", 1)
        else:
            cell[1] += (r["outcome"] == "silent", 1)
        cell[2] += (r["window_alarmed"], r["window_frames"])
        cell[3] += (r["clear_silent"], r["clear_frames"])
    return Parts(seeds, sums.reshape(len(seeds), -1), tuple(float(j) for j in levels))


def metrics(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The track's raw metrics: approach hit rate and clear clips' false-alarm rate with
    95% Wilson intervals, false alarms per minute of clear frames, the median lead time of
    the hits, the ROC AUC of the potential (window frames against clear ones); per
    scenario, the outcomes."""
    from lgmd_sim.signals.metrics import roc_auc, wilson_interval

    approach = [r for r in records if r["kind"] == "approach"]
    clear = [r for r in records if r["kind"] == "clear"]
    hits = sum(r["outcome"] == "hit" for r in approach)
    alarmed = sum(r["outcome"] == "false_alarm" for r in clear)
    minutes = sum(r["clear_frames"] / r["fps"] for r in records) / 60
    leads = [r["lead_s"] for r in approach if r["outcome"] == "hit"]
    scores, labels = [], []
    for r in records:
        for p, window, clear_frame in zip(r["potentials"], r["window"], r["clear"],
                                          strict=True):
            if window or clear_frame:
                scores.append(p)
                labels.append(window)
    outcomes: dict[str, dict[str, int]] = {}
    for r in records:
        counts = outcomes.setdefault(r["scenario"], {})
        counts[r["outcome"]] = counts.get(r["outcome"], 0) + 1
    return {"hit_rate": hits / len(approach),
            "hit_ci": list(wilson_interval(hits, len(approach))),
            "false_alarm_rate": alarmed / len(clear),
            "false_alarm_ci": list(wilson_interval(alarmed, len(clear))),
            "false_alarms_per_min": (sum(r["clear_onsets"] for r in records) / minutes
                                     if minutes else None),
            "median_lead_s": float(np.median(leads)) if leads else None,
            "auc": roc_auc(scores, labels),
            "outcomes": outcomes}
