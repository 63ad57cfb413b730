"""The detection loop: models over a clip's frames, one frame at a time, and the clip's
metrics (`detect`), or over a video file or image folder (`detect_video`)."""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.core.frames import to_grey
from lgmd_sim.core.params import checked, positive
from lgmd_sim.detect.results import Detection, ModelTrace
from lgmd_sim.detect.specs import detector_names, with_preset
from lgmd_sim.models.base import LGMDModel
from lgmd_sim.signals import metrics
from lgmd_sim.signals import noise as noise_lib
from lgmd_sim.signals.video import VideoReader

__all__ = ["check_collision_frame", "detect", "detect_video"]


def _front_end(model: LGMDModel) -> tuple[str, float] | None:
    """A model's front ends as a spec suffix ("image+gain") and its field of view."""
    p = model.params
    parts = [p.stabilize] * (p.stabilize != "none") + ["gain"] * bool(p.gain)
    return ("+".join(parts), float(p.fovy)) if parts else None


def _build(spec: str | Sequence[str] | Mapping[str, LGMDModel]) -> dict[str, LGMDModel]:
    if isinstance(spec, Mapping):
        if not spec:
            raise ValueError("no models")
        for m in spec.values():
            m.reset()
        return dict(spec)
    return with_preset(detector_names(spec), None)


def check_collision_frame(collision_frame: int, n_frames: int, name: str) -> None:
    """A labelled collision frame must be one of the clip's frames."""
    if not 0 <= collision_frame < n_frames:
        raise ValueError(f"{name}: collision frame {collision_frame} is outside its frames "
                         f"0..{n_frames - 1}")


def detect(
    frames: Iterable[np.ndarray],
    fps: float,
    model_spec: str | Sequence[str] | Mapping[str, LGMDModel] = "all",
    collision_frame: int | None = None,
    *,
    name: str = "",
    total: int | None = None,
    progress: bool | None = False,
    window_s: float = 1.0,
    noise: str | Sequence[noise_lib.Noise] | None = None,
    noise_seed: int = 0,
    infos: Sequence[Mapping[str, Any]] | None = None,
) -> Detection:
    """Run models over a clip, frame by frame, and compute the clip's metrics.

    Args:
        frames: grey (H, W) or RGB (H, W, 3) frames, uint8 or float in 0..1.
        fps: frames per second of the clip.
        model_spec: "all", detectors (a list or a comma-separated string), each
            MODEL[/PRESET][+FRONT...] with video front ends (`lgmd_sim.detect.specs`), or
            a mapping of name -> built model (reset before use).
        collision_frame: labelled collision frame (0-based); adds the event metrics.
        name: the clip's name, for the result and the progress bar.
        total: number of frames if known (for the progress bar).
        progress: show a progress bar on stderr (None: only on a terminal).
        window_s: tolerance window of the event metrics, seconds before the collision.
        noise: corrupt every frame (uint8) before the models and the SSIM see it:
            "kind:level,..." or a list of `lgmd_sim.signals.noise.Noise` (see that module).
        noise_seed: the noise's seed; frame t's noise depends only on it and t.
        infos: a simulated clip's ``info`` of every frame, for models that compensate the
            camera's rotation from the pose or the IMU (``stabilize="pose"`` or
            ``"imu"``: each frame's ``info[model.rotation_key]``).
    """
    from tqdm import tqdm

    checked(f"{name or 'clip'}: fps", fps, positive)
    built = _build(model_spec)
    needs = sorted({m.rotation_key for m in built.values()} - {None})
    if needs and infos is None:
        raise ValueError(f"{name or 'clip'}: the models need {', '.join(needs)} from each "
                         "frame's info: pass infos")
    noises = noise_lib.parse(noise)
    if noises:
        frames = noise_lib.corrupt(frames, noises, noise_seed)
    potentials: dict[str, list[float]] = {n: [] for n in built}
    alarms: dict[str, list[bool]] = {n: [] for n in built}
    ssims = [math.nan]
    prev = None
    bar = tqdm(frames, total=total, desc=Path(name).name or None, unit="frame",
               disable=None if progress is None else not progress, file=sys.stderr, leave=False)
    for frame in bar:
        grey = to_grey(frame, name or "clip")
        if prev is not None:
            if prev.shape != grey.shape:
                raise ValueError(f"{name or 'clip'}: frame {len(ssims)} is "
                                 f"{grey.shape[0]}x{grey.shape[1]}, earlier frames are "
                                 f"{prev.shape[0]}x{prev.shape[1]}")
            ssims.append(metrics.ssim(prev, grey))
        prev = grey
        for n, model in built.items():
            out = model.step(grey, rotation=model.rotation_from(infos[len(ssims) - 1])
                             if model.rotation_key else None)
            potentials[n].append(out.potential)
            alarms[n].append(out.alarm)
    n_frames = 0 if prev is None else len(ssims)
    if n_frames < 2:
        raise ValueError(f"{name or 'clip'}: needs at least 2 frames, got {n_frames}")
    if collision_frame is not None:
        check_collision_frame(collision_frame, n_frames, name or "clip")
    traces = {}
    for n, model in built.items():
        mp = np.asarray(potentials[n], np.float64)
        alarm = np.asarray(alarms[n], bool)
        threshold = float(model.params.threshold)
        event = None if collision_frame is None else metrics.evaluate_clip(
            alarm, collision_frame, fps, window_s=window_s
        )
        traces[n] = ModelTrace(threshold, mp, alarm, metrics.sensitivity_index(
                                   mp, threshold, model.alarm_rule),
                               metrics.mpsi(mp), event, _front_end(model), model.alarm_rule)
    ssim = np.asarray(ssims)
    return Detection(name, n_frames, float(fps), ssim, float(ssim[1:].mean()),
                     collision_frame, traces, ",".join(map(str, noises)) or None,
                     int(noise_seed) if noises else None)


def detect_video(
    path: str | os.PathLike,
    model_spec: str | Sequence[str] | Mapping[str, LGMDModel] = "all",
    collision_frame: int | None = None,
    *,
    progress: bool | None = False,
    window_s: float = 1.0,
    noise: str | Sequence[noise_lib.Noise] | None = None,
    noise_seed: int = 0,
) -> Detection:
    """`detect` over a video file or image folder (see `lgmd_sim.signals.video.VideoReader`)."""
    clip = VideoReader(path)
    return detect(clip, clip.fps, model_spec, collision_frame, name=str(path),
                  total=clip.frame_count, progress=progress, window_s=window_s,
                  noise=noise, noise_seed=noise_seed)
