"""What a detection gives back: each model's response to a clip (`ModelTrace`) and the
clip's (`Detection`), with the paper's metrics, JSON-ready."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.signals import metrics

__all__ = ["Detection", "ModelTrace"]


@dataclass(frozen=True, eq=False)
class ModelTrace:
    """One model's response to a clip.

    Attributes:
        threshold: the model's alarm threshold.
        potential: (T,) membrane potential per frame.
        alarm: (T,) alarm flag per frame (potential above the threshold).
        sensitivity: SI (Eq. 23) with its never-crossed flag.
        mpsi: MpSI (Eq. 22).
        event: hit / miss against the labelled collision frame, None when unlabelled.
        front_end: the model's ego-motion compensation ("image", "gain", "image+gain"...,
            see `lgmd_sim.models.stabilize`) and the field of view it assumed, or None.
        alarm_rule: when the potential alarms (the model's ``alarm_frames`` and
            ``alarm_rising``).
    """

    threshold: float
    potential: np.ndarray
    alarm: np.ndarray
    sensitivity: metrics.Sensitivity
    mpsi: float
    event: metrics.EventResult | None
    front_end: tuple[str, float] | None = None
    alarm_rule: metrics.AlarmRule = metrics.PAPER_ALARM

    @property
    def first_alarm(self) -> int | None:
        return self.sensitivity.first_alarm

    def summary(self, series: bool = False) -> dict[str, Any]:
        """JSON-ready metrics; with ``series``, the membrane potential of every frame."""
        out: dict[str, Any] = {
            "first_alarm": self.first_alarm,
            "si": self.sensitivity.si,
            "si_crossed": self.sensitivity.crossed,
            "mpsi": self.mpsi,
            "peak_potential": float(self.potential.max()),
            "threshold": self.threshold,
            "alarm_frames": self.alarm_rule.frames,
            "alarm_rising": self.alarm_rule.rising,
            "stabilize": None if self.front_end is None else self.front_end[0],
            "fovy": None if self.front_end is None else self.front_end[1],
        }
        if self.event is not None:
            ev = self.event
            out.update(outcome=ev.outcome, lead_frames=ev.lead_frames, lead_s=ev.lead_s,
                       window_frames=ev.window_frames)
        if series:
            out["membrane_potential"] = [round(float(v), 6) for v in self.potential]
        return out


@dataclass(frozen=True, eq=False)
class Detection:
    """Every model's response to one clip, and the clip's frame-to-frame similarity.

    Attributes:
        video: the clip's name or path.
        frames: number of frames.
        fps: frames per second.
        ssim: (T,) SSIM of each frame with the previous one, NaN for frame 0.
        isi: ISI (Eq. 21), the mean of ``ssim[1:]``.
        collision_frame: the labelled collision frame, or None.
        models: model name -> its `ModelTrace`, in the order asked for.
        noise: the noise the frames were corrupted with ("kind:level,..."), or None.
        noise_seed: the noise's seed, or None without noise.
    """

    video: str
    frames: int
    fps: float
    ssim: np.ndarray
    isi: float
    collision_frame: int | None
    models: Mapping[str, ModelTrace]
    noise: str | None = None
    noise_seed: int | None = None

    def summary(self, series: bool = False) -> dict[str, Any]:
        """JSON-ready summary (the ``--json`` record); see `ModelTrace.summary`."""
        return {
            "video": self.video,
            "frames": self.frames,
            "fps": self.fps,
            "isi": self.isi,
            "collision_frame": self.collision_frame,
            "noise": self.noise,
            "noise_seed": self.noise_seed,
            "models": {name: t.summary(series) for name, t in self.models.items()},
        }
