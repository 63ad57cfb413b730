"""`lgmd-sim detect` as a job: models over each video in turn, its files written and a
line (or a JSON record) printed per video; a bad video is reported and skipped."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

from lgmd_sim.core.configfile import setting
from lgmd_sim.core.fileio import error_text
from lgmd_sim.core.params import checked, in_range, seed
from lgmd_sim.detect.clip import check_collision_frame, detect
from lgmd_sim.detect.outputs import check_out_folder, output_names, write_outputs
from lgmd_sim.detect.specs import detector, detector_names, front_end_params, with_preset
from lgmd_sim.signals import noise as noise_lib
from lgmd_sim.signals.video import VideoReader

__all__ = ["FOV", "DetectConfig", "Video", "run"]

#: A camera's vertical field of view, in degrees.
FOV = in_range(1.0, 179.0)


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
    naming it). Each field but `videos` is declared with its meaning
    (`lgmd_sim.core.configfile.setting`): the command's options.

    Attributes:
        videos: the inputs: video files or image folders (a path), or `Video`s.
    """

    videos: tuple[str | Video, ...]
    models: tuple[str, ...] = setting(
        ("all",), "all (every model `lgmd-sim models` lists) or a list of "
        "MODEL[/PRESET][+FRONT...]: a model name or a plug-in's 'package.module:Class' spec, "
        "optionally with its preset and the front ends a video can have, +image and +gain "
        "(e.g. lgmd1/robot-image,feedback+gain)")
    preset: str | None = setting(
        None, "run each model listed without a preset at this one where it has it, e.g. "
        "calibrated (see `lgmd-sim models`); the others at their default. A model listed "
        "with another preset (MODEL/PRESET) is refused: give its preset once")
    collision_frame: int | None = setting(
        None, "the labelled collision frame (0-based) of every video, over a dataset "
        "episode's own: marked in the figure, and used to score each model: a hit when its "
        "first alarm falls in the window before this frame, this frame included (lead 0 s: "
        "an alarm with the collision, too late to act on), otherwise a miss (early, late or "
        "none), as `bench open-loop` and the published evaluation count it "
        "(`lgmd_sim.signals.metrics.evaluate_clip`)")
    window: float = setting(1.0, "the hit window, seconds before the collision frame")
    out: str | None = setting(
        None, "write <name>.csv, <name>.json and <name>.png per video into this folder "
        "(unset: ./detect-out, but for json_lines: no files). <name> is the video's stem, "
        "or its file name where two videos share a stem")
    json_lines: bool = setting(False, "print one JSON object per video to stdout (with the "
                               "membrane potential of every frame)")
    noise: str | None = setting(
        None, "corrupt every frame before the models and the SSIM see it, as the paper's "
        "noisy streams: comma-separated kind:level of gaussian (variance on the [0, 1] "
        "scale, the paper's 0.001 to 0.009), saltpepper (density, 0.001 to 0.009), shake "
        "(extra rotation, translation and brightness gain, level 1: about 1 degree and 2 "
        "pixels), and a real camera's: exposure (a smoothly drifting gain, level 1: about "
        "10%), sensor (signal-dependent noise), blur (motion blur, level 1: about 3 pixels) "
        "and jpeg (compression at quality 1 to 100), e.g. gaussian:0.005,saltpepper:0.005; "
        "recorded in the JSON summary (`lgmd_sim.signals.noise`)")
    noise_seed: int = setting(0, "seed of the noise; frame t's noise depends only on the "
                              "seed, the noise and t")
    stabilize: str = setting(
        "none", "ego-motion compensation before every model: 'image' removes the camera's "
        "rotation between frames, fitted from the frames alone (it needs the camera's field "
        "of view, fov); 'gain' removes brightness changes between frames; 'image+gain' "
        "both; a model listed with front ends of its own (+image) is refused with it. "
        "Recorded per model in the JSON summary")
    fov: float = setting(55.0, "the camera's vertical field of view in degrees, 1 to 179, "
                         "for stabilize image (55: the simulator's camera)")
    progress: bool | None = setting(None, "show a progress bar (unset: only on a terminal)")

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
        checked("fov", self.fov, FOV)

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
