"""`lgmd-sim detect` as a job: models over each video in turn, its files written and a
line (or a JSON record) printed per video; a bad video is reported and skipped."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

from lgmd_sim.core.fileio import error_text
from lgmd_sim.core.params import checked, in_range, seed
from lgmd_sim.detect.clip import check_collision_frame, detect
from lgmd_sim.detect.outputs import check_out_folder, output_names, write_outputs
from lgmd_sim.detect.specs import detector, detector_names, front_end_params, with_preset
from lgmd_sim.signals import noise as noise_lib
from lgmd_sim.signals.video import VideoReader

__all__ = ["DetectConfig", "Video", "run"]


@dataclass(frozen=True)
class Video:
    """One input: its name (for messages and output names), the file or image folder to
    read, and its labelled collision frame (a dataset episode's), if any."""

    name: str
    source: str
    collision_frame: int | None = None


@dataclass(frozen=True)
class DetectConfig:
    """What `run` does, checked when it is made (a bad value raises a one-line ValueError
    naming it).

    Attributes:
        videos: the inputs: video files or image folders (a path), or `Video`s.
        models: detectors, each MODEL, MODEL/PRESET or either with video front ends
            ("lgmd1/robot-image", "lgmd1+image+gain"), or ("all",): every model.
        preset: run every model listed without a preset at this one where it has it (the
            others at their default); a model listed with another preset is refused.
        collision_frame: the labelled collision frame of every video (over a `Video`'s own).
        window: a first alarm within this many seconds before the collision frame, that
            frame included, is a hit (`lgmd_sim.signals.metrics.evaluate_clip`, as the benchmarks
            count it).
        out: the output folder; None: ``detect-out``, or no files with `json_lines`.
        json_lines: print one JSON record per video instead of a line.
        noise: corrupt every frame first ("kind:level,...", `lgmd_sim.signals.noise`).
        noise_seed: the noise's seed.
        stabilize: front ends for videos: "none", "image", "gain" or "image+gain".
        fov: the camera's vertical field of view (degrees), for the "image" front end.
        progress: show a progress bar (None: only on a terminal).
    """

    videos: tuple[str | Video, ...]
    models: tuple[str, ...] = ("all",)
    preset: str | None = None
    collision_frame: int | None = None
    window: float = 1.0
    out: str | None = None
    json_lines: bool = False
    noise: str | None = None
    noise_seed: int = 0
    stabilize: str = "none"
    fov: float = 55.0
    progress: bool | None = None

    def __post_init__(self) -> None:
        if not self.videos:
            raise ValueError("no videos given")
        object.__setattr__(self, "videos", tuple(
            v if isinstance(v, Video) else Video(str(v), str(v)) for v in self.videos))
        object.__setattr__(self, "models", tuple(detector_names(self.models)))
        noise_lib.parse(self.noise)  # a bad spec fails before any video is read
        front = front_end_params(self.stabilize, self.fov)
        for m in self.models:  # their presets and front ends, before any video is read
            detector(m, self.preset, self.fov, **front)
        checked("noise_seed", self.noise_seed, seed)
        if self.collision_frame is not None:
            checked("collision_frame", self.collision_frame, seed)
        checked("window", self.window, in_range(0, 3600))

    @property
    def out_folder(self) -> Path | None:
        return Path(self.out) if self.out else None if self.json_lines else Path("detect-out")


def run(config: DetectConfig) -> int:
    """Every video of `config` in turn: 0 when all ran, 2 when one or more could not."""
    built = with_preset(config.models, config.preset, config.fov,
                        **front_end_params(config.stabilize, config.fov))
    noises = noise_lib.parse(config.noise)
    out = config.out_folder
    if out is not None:
        check_out_folder(out)
    failed = 0
    stems = output_names([v.name for v in config.videos])
    for video, stem in zip(config.videos, stems, strict=True):
        collision_frame = (video.collision_frame if config.collision_frame is None
                           else config.collision_frame)
        try:
            clip = VideoReader(video.source)
            if clip.frame_count is not None and collision_frame is not None:
                check_collision_frame(collision_frame, clip.frame_count, video.name)
            d = detect(clip, clip.fps, built, collision_frame, name=video.name,
                       total=clip.frame_count, progress=config.progress,
                       noise=noises, noise_seed=config.noise_seed, window_s=config.window)
            paths = write_outputs(d, out, stem) if out is not None else {}
        except (ValueError, OSError) as exc:
            print(f"lgmd-sim detect: error: {error_text(exc)}", file=sys.stderr)
            failed += 1
            continue
        if config.json_lines:
            record = d.summary(series=True)
            record["outputs"] = {ext: str(p) for ext, p in paths.items()}
            print(json.dumps(record, allow_nan=False), flush=True)
        else:
            alarms = ", ".join(
                f"{n} {'no alarm' if t.first_alarm is None else f'alarm at {t.first_alarm}'}"
                for n, t in d.models.items()
            )
            print(f"{video.name}: {d.frames} frames, ISI {d.isi:.4f}; {alarms}; "
                  f"wrote {', '.join(str(p) for p in paths.values())}")
    return 2 if failed else 0
