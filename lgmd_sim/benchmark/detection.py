"""The detection track: a detector alone on synthetic clips, no controller. Every clip
is a stimulus drawn from its seed and shaken at a jitter level as the video calibration
draws them (`lgmd_sim.calibration.clips.stimulus_clip`), so that the same protocol gives every
entry the same clips; `clip_job` runs one and judges its alarms.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lgmd_sim.benchmark.protocol import DetectionTrack

__all__ = ["ClipKey", "auc", "clip_job", "clips", "key", "metrics"]

#: A clip of the track: (stimulus, jitter level, seed).
ClipKey = tuple[str, float, int]


def clips(track: DetectionTrack) -> list[ClipKey]:
    """Every clip of the track, approaching stimuli first."""
    return [(name, j, s) for name in (*track.approaching, *track.non_approach)
            for j in track.jitter for s in track.seeds]


def key(clip: ClipKey) -> str:
    """A clip's record name."""
    name, jitter, seed = clip
    return f"{name}-j{jitter:g}-s{seed}"


def clip_job(clip: ClipKey, model: str, preset: str, resolution: Any, approaching: bool,
             window_s: float) -> dict[str, Any]:
    """Run detector (`model`, `preset`) on one clip (a job: runs in a worker) and judge its
    alarms: a hit is the first alarm within `window_s` before the collision, a false alarm
    any alarm on a clip that does not loom. A front end that needs the camera's rotation
    (imu, pose) gets none: the clips have no camera, only their shake.

    The record keeps each frame's potential and whether it is in the window (ROC AUC
    pools them: in the window against every frame of the clips that do not loom)."""
    from lgmd_sim import models
    from lgmd_sim.calibration.clips import stimulus_clip
    from lgmd_sim.signals import metrics

    name, jitter, seed = clip
    stimulus = stimulus_clip(name, jitter, seed, resolution)
    model_ = models.make(model, preset=preset)
    still = np.zeros(3) if model_.rotation_key is not None else None
    outs = [model_.step(f, rotation=still) for f in stimulus.frames]
    potentials = [float(o.potential) for o in outs]
    alarms = [bool(o.alarm) for o in outs]
    hit = stimulus.collision_frame if approaching else None
    if hit is not None and hit < 0:
        hit = None
    judged = metrics.evaluate_clip(np.array(alarms, float), hit, stimulus.fps,
                                   window_s=window_s)
    window = round(window_s * stimulus.fps)
    near = [hit is not None and hit - window <= t <= hit for t in range(len(potentials))]
    return {"stimulus": name, "jitter": jitter, "seed": seed, "approaching": approaching,
            "frames": len(potentials), "collision_frame": hit,
            "first_alarm": judged.first_alarm,
            "outcome": judged.outcome, "lead_s": judged.lead_s,
            "potentials": potentials, "near": near}


def auc(records: Sequence[Mapping[str, Any]]) -> float | None:
    """ROC AUC of the frames' potentials: the frames in the window before a collision
    against every frame of the clips that do not loom."""
    from lgmd_sim.signals import metrics

    scores, labels = [], []
    for r in records:
        for p, near in zip(r["potentials"], r["near"], strict=True):
            if near or not r["approaching"]:
                scores.append(p)
                labels.append(near)
    return metrics.roc_auc(scores, labels)


def metrics(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The track's raw metrics: hit rate and false-alarm rate with 95% Wilson intervals,
    the median lead time of the hits, ROC AUC; per stimulus, the alarms."""
    from lgmd_sim.signals.metrics import wilson_interval

    approach = [r for r in records if r["approaching"]]
    other = [r for r in records if not r["approaching"]]
    hits = sum(r["outcome"] == "hit" for r in approach)
    alarms = sum(r["outcome"] == "false_alarm" for r in other)
    leads = [r["lead_s"] for r in approach if r["outcome"] == "hit" and r["lead_s"] is not None]
    by_stimulus: dict[str, list[int]] = {}
    for r in records:
        counts = by_stimulus.setdefault(r["stimulus"], [0, 0])
        counts[0] += r["first_alarm"] is not None
        counts[1] += 1
    return {"hit_rate": hits / len(approach), "hit_ci": list(wilson_interval(hits, len(approach))),
            "false_alarm_rate": alarms / len(other),
            "false_alarm_ci": list(wilson_interval(alarms, len(other))),
            "median_lead_s": float(np.median(leads)) if leads else None, "auc": auc(records),
            "alarmed": {k: f"{a}/{n}" for k, (a, n) in by_stimulus.items()}}
