"""`lgmd-sim detect`: run LGMD models over videos; write a CSV, a JSON summary and a figure.

The library entry points are `detect` (any sequence of frames) and `detect_video` (a
video file or image folder); both return a `Detection`:

>>> from lgmd_sim.detect import detect_video
>>> d = detect_video("run.mp4", ["feedback", "lgmd2"], collision_frame=120)
>>> d.isi, d.models["feedback"].first_alarm, d.models["feedback"].event.outcome
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import metrics, models
from lgmd_sim import noise as noise_lib
from lgmd_sim.fileio import write_files
from lgmd_sim.frames import to_grey
from lgmd_sim.models.base import LGMDModel
from lgmd_sim.video import VideoReader

__all__ = ["Detection", "ModelTrace", "detect", "detect_video", "front_end_params",
           "output_names", "parse_models", "run", "with_preset", "write_outputs"]


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
    """

    threshold: float
    potential: np.ndarray
    alarm: np.ndarray
    sensitivity: metrics.Sensitivity
    mpsi: float
    event: metrics.EventResult | None
    front_end: tuple[str, float] | None = None

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


def parse_models(spec: str | Sequence[str]) -> list[str]:
    """Model names from "all", a comma-separated list, or a sequence; unknown names fail."""
    names = spec.split(",") if isinstance(spec, str) else list(spec)
    names = [n.strip() for n in names if n.strip()]
    if names == ["all"]:
        return models.available()
    unknown = [n for n in names if n not in models.available()]
    if unknown or not names:
        what = f"unknown model(s) {', '.join(map(repr, unknown))}" if unknown else "no models"
        raise ValueError(f"{what}; valid: all, {', '.join(models.available())}")
    return list(dict.fromkeys(names))  # drop repeats, keep order


def with_preset(names: Sequence[str], preset: str | None, **front: Any
                ) -> dict[str, LGMDModel]:
    """The models `names`, each at `preset` where it has one (named "model/preset"), else
    at its default (named "model"); ``front`` (`front_end_params`) gives each the same
    ego-motion compensation."""
    if preset is not None and not any(preset in models.model_class(n).presets for n in names):
        raise ValueError(f"none of the models {', '.join(names)} has a preset {preset!r}")
    built = {}
    for name in names:
        if preset is not None and preset in models.model_class(name).presets:
            built[f"{name}/{preset}"] = models.make(name, preset=preset, **front)
        else:
            built[name] = models.make(name, **front)
    return built


#: The front ends a video can have: its frames are all there is (no pose, no IMU).
VIDEO_FRONT_ENDS = ("image", "gain")


def front_end_params(stabilize: str | None, fovy: float) -> dict[str, Any]:
    """Model parameters of front ends for videos, "+"-separated: "image" (the camera's
    rotation between frames, fitted from the frames, with the vertical field of view
    `fovy` in degrees), "gain" (the brightness gain between frames) or "image+gain";
    None or "none": {} (none)."""
    if stabilize is None or stabilize == "none":
        return {}
    given = stabilize.split("+")
    if any(f not in VIDEO_FRONT_ENDS for f in given) or len(set(given)) < len(given):
        raise ValueError(f"--stabilize {stabilize!r}: give image, gain or image+gain (a video "
                         "has no pose or IMU to take the rotation from)")
    return {"stabilize": "image" if "image" in given else "none", "gain": "gain" in given,
            "fovy": fovy}


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
    return {name: models.make(name) for name in parse_models(spec)}


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
        model_spec: "all", model names (a list or a comma-separated string), or a mapping
            of name -> built model (reset before use), e.g. for another preset.
        collision_frame: labelled collision frame (0-based); adds the event metrics.
        name: the clip's name, for the result and the progress bar.
        total: number of frames if known (for the progress bar).
        progress: show a progress bar on stderr (None: only on a terminal).
        window_s: tolerance window of the event metrics, seconds before the collision.
        noise: corrupt every frame (uint8) before the models and the SSIM see it:
            "kind:level,..." or a list of `lgmd_sim.noise.Noise` (see `lgmd_sim.noise`).
        noise_seed: the noise's seed; frame t's noise depends only on it and t.
        infos: a simulated clip's ``info`` of every frame, for models that compensate the
            camera's rotation from the pose or the IMU (``stabilize="pose"`` or
            ``"imu"``: each frame's ``info[model.rotation_key]``).
    """
    from tqdm import tqdm

    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"{name or 'clip'}: fps must be a finite number > 0, got {fps!r}")
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
        traces[n] = ModelTrace(threshold, mp, alarm, metrics.sensitivity_index(mp, threshold),
                               metrics.mpsi(mp), event, _front_end(model))
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
    """`detect` over a video file or image folder (see `lgmd_sim.video.VideoReader`)."""
    clip = VideoReader(path)
    return detect(clip, clip.fps, model_spec, collision_frame, name=str(path),
                  total=clip.frame_count, progress=progress, window_s=window_s,
                  noise=noise, noise_seed=noise_seed)


# --- outputs ------------------------------------------------------------------------------


def _write_csv(path: Path, d: Detection) -> None:
    names = list(d.models)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["frame", "time_s", "ssim"]
                   + [c for n in names for c in (f"{n}_potential", f"{n}_alarm")])
        for t in range(d.frames):
            row: list[Any] = [t, f"{t / d.fps:.6f}", "" if t == 0 else f"{d.ssim[t]:.6f}"]
            for n in names:
                tr = d.models[n]
                row += [f"{tr.potential[t]:.6f}", int(tr.alarm[t])]
            w.writerow(row)


def _write_figure(path: Path, d: Detection) -> None:
    """The paper's layout: every model's potential with the threshold, each first alarm
    and the collision marked; the SSIM of consecutive frames below."""
    from lgmd_sim.plots import COLLISION, draw_potentials, figure

    fig = figure(figsize=(10, 5.8))
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=[2.2, 1])
    draw_potentials(top, d)
    top.set_xlabel("")  # shared with the SSIM panel below
    top.set_title(Path(d.video).name)
    if d.collision_frame is not None:
        bottom.axvline(d.collision_frame, **COLLISION)
    bottom.plot(np.arange(1, d.frames), d.ssim[1:], color="0.35", lw=1.2)
    bottom.set_ylabel("SSIM")
    bottom.set_xlabel("frame")
    bottom.set_title(f"SSIM of consecutive frames (ISI {d.isi:.4f})", fontsize="medium")
    bottom.set_ylim(min(0.0, float(np.min(d.ssim[1:]))), 1.02)
    fig.savefig(path, format="png", dpi=120)


def write_outputs(d: Detection, out_dir: str | os.PathLike, stem: str) -> dict[str, Path]:
    """Write <stem>.csv, <stem>.json and <stem>.png into out_dir: the set as a whole, or
    (on any error) none of it, the previous set left as it was."""
    out_dir = Path(out_dir)
    paths = {ext: out_dir / f"{stem}.{ext}" for ext in ("csv", "json", "png")}
    write_files({
        paths["csv"]: lambda tmp: _write_csv(tmp, d),
        paths["json"]: lambda tmp: tmp.write_text(
            json.dumps(d.summary(), indent=2, allow_nan=False) + "\n"),
        paths["png"]: lambda tmp: _write_figure(tmp, d),
    })
    return paths


def output_names(videos: Sequence[str]) -> list[str]:
    """Unique, predictable output names: each video's stem; where stems are shared, the
    file name (``clip.avi``, ``clip.mp4``); where those are shared too, the parent folder
    joined on (``day1_clip.mp4``); and where a name is still taken, ``~2``, ``~3``..."""
    paths = [Path(os.path.normpath(v)) for v in videos]
    levels = [
        [p.stem or "video" for p in paths],
        [p.name or "video" for p in paths],
        ["_".join(p.parts[-2:]) or "video" for p in paths],
    ]
    names: list[str] = []
    taken: set[str] = set()  # case-folded: some file systems ignore case
    for i in range(len(paths)):
        name = next((lv[i] for lv in levels
                     if [x.casefold() for x in lv].count(lv[i].casefold()) == 1), levels[-1][i])
        base, k = name, 1
        while name.casefold() in taken:
            k += 1
            name = f"{base}~{k}"
        taken.add(name.casefold())
        names.append(name)
    return names


def _check_out_folder(out: Path) -> None:
    """Fail before any frame is processed if the output folder could not be written
    (it is made only when the first result is written)."""
    existing = out.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        what = "is a file" if existing == out.absolute() else f"is inside the file {existing}"
        raise ValueError(f"output folder {out} {what}, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write output folder {out}: permission denied on {existing}")


def run(args: argparse.Namespace) -> int:
    """`lgmd-sim detect`: every video in turn; a bad one is reported and skipped (exit 2)."""
    built = with_preset(parse_models(args.models), args.preset,
                        **front_end_params(args.stabilize, args.fov))
    noises = noise_lib.parse(args.noise)  # a bad spec fails before any video is read
    out = Path(args.out) if args.out else None if args.json else Path("detect-out")
    if out is not None:
        _check_out_folder(out)
    failed = 0
    from lgmd_sim.data import detect_inputs  # a dataset (or DIR:N) becomes its episodes

    inputs = detect_inputs(args.videos)  # (name, video file, labelled collision frame)
    for (video, source, labelled), stem in zip(inputs, output_names([i[0] for i in inputs]),
                                               strict=True):
        collision_frame = labelled if args.collision_frame is None else args.collision_frame
        try:
            clip = VideoReader(source)
            if clip.frame_count is not None and collision_frame is not None:
                check_collision_frame(collision_frame, clip.frame_count, video)
            d = detect(clip, clip.fps, built, collision_frame, name=str(video),
                       total=clip.frame_count,
                       progress=False if args.no_progress else None,
                       noise=noises, noise_seed=args.noise_seed)
            paths = write_outputs(d, out, stem) if out is not None else {}
        except (ValueError, OSError) as exc:
            print(f"lgmd-sim detect: error: {exc}", file=sys.stderr)
            failed += 1
            continue
        if args.json:
            record = d.summary(series=True)
            record["outputs"] = {ext: str(p) for ext, p in paths.items()}
            print(json.dumps(record, allow_nan=False), flush=True)
        else:
            alarms = ", ".join(
                f"{n} {'no alarm' if t.first_alarm is None else f'alarm at {t.first_alarm}'}"
                for n, t in d.models.items()
            )
            print(f"{video}: {d.frames} frames, ISI {d.isi:.4f}; {alarms}; "
                  f"wrote {', '.join(str(p) for p in paths.values())}")
    return 2 if failed else 0
