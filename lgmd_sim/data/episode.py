"""One episode of a dataset (`make_episode`): it drives a scenario with a controller,
encodes the camera frames and builds the per-frame labels, and hands both back as bytes.

Apart from the job (`lgmd_sim.data.generate`) because this is what runs in a worker, in
this process, a local pool or a Ray task: it depends on its `EpisodeSpec` only (the same
bytes wherever it runs) and writes nothing into the dataset folder, which only the job's
process does.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from lgmd_sim.core.fileio import scratch_folder
from lgmd_sim.data import layout

__all__ = ["EpisodeResult", "EpisodeSpec", "make_episode"]


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode to make: everything `make_episode` needs."""

    index: int
    scenario: str
    task_index: int
    jitter: float
    seed: int
    overrides: Mapping[str, Any]
    controller: str
    models: tuple[str, ...]
    noise: tuple[str, ...]
    video: str

    @property
    def key(self) -> str:
        return f"episode {self.index} ({self.scenario}, jitter {self.jitter:g}, seed {self.seed})"


@dataclass(frozen=True)
class EpisodeResult:
    """A made episode: its encoded video, its data file (Parquet) and its metadata."""

    video: bytes
    data: bytes
    meta: dict[str, Any]


def make_episode(spec: EpisodeSpec) -> EpisodeResult:
    """Run one episode and encode it: its video, its labels as a Parquet file, its
    metadata. Depends on `spec` only (the same bytes wherever it runs)."""
    from lgmd_sim import __version__, controllers, models
    from lgmd_sim.controllers import rollout
    from lgmd_sim.core.frames import to_grey
    from lgmd_sim.envs.reuse import episode_env
    from lgmd_sim.signals import noise
    from lgmd_sim.signals.video import encoder

    fmt = layout.VIDEO_FORMATS[spec.video]
    variants = {v: noise.parse(v.replace("+", ",")) for v in spec.noise}
    # A set of models per stream seen: the clean frames (None) and each noise variant.
    built = {v: {m: models.make(m) for m in spec.models}
             for v in [None, *variants]} if spec.models else {}
    controller = controllers.make(spec.controller)
    columns: dict[str, list] = {name: [] for name in layout.label_schema(spec.models,
                                                                         spec.noise).names}
    nan3 = np.full(3, np.nan, np.float32)
    with episode_env(spec.scenario, ssim=True, **spec.overrides) as env:  # ssim: a label
        params = env.unwrapped.params
        with scratch_folder("lgmd-sim-episode") as tmp:
            video = tmp / f"episode{fmt.suffix}"
            # not video_writer: its codec follows the suffix (FFV1 for .avi), and its
            # atomic rename is not needed in a job's private temporary folder
            with encoder(video, fmt.fourcc, params.fps, params.size) as write:
                for step in rollout(env, controller, seed=spec.seed):
                    rgb = step.obs["frame"]
                    if rgb.shape[-1] == 1:  # a grey scenario (frame="grey")
                        rgb = rgb.repeat(3, axis=-1)
                    write(rgb)
                    _append_labels(columns, spec, step, params.fps, nan3)
                    for variant, by_model in built.items():
                        seen = rgb if variant is None else noise.apply(
                            rgb, variants[variant], spec.seed, step.index)
                        grey = to_grey(seen)
                        for name, model in by_model.items():
                            out = model.step(grey)
                            potential, alarm = layout.model_columns(name, variant)
                            columns[potential].append(out.potential)
                            columns[alarm].append(out.alarm)
            video_bytes = video.read_bytes()
        env_params = dataclasses.asdict(params)
    meta = _episode_meta(spec, columns, params.fps, params.size)
    meta.update(
        version=__version__, video_codec=fmt.codec, video_sha256=_sha256_bytes(video_bytes),
        config={"env": env_params, "controller": {
            "name": spec.controller, "params": dataclasses.asdict(controller.params)},
            "models": {m: dataclasses.asdict(model.params)
                       for m, model in built.get(None, {}).items()},
            "noise": list(spec.noise)})
    return EpisodeResult(video_bytes, _parquet_bytes(columns, spec, meta), meta)


def _append_labels(columns: dict[str, list], spec: EpisodeSpec, step: Any, fps: float,
                   nan3: np.ndarray) -> None:
    info, obs = step.info, step.obs
    columns["episode_index"].append(spec.index)
    columns["frame_index"].append(step.index)
    columns["timestamp"].append(step.index / fps)
    columns["index"].append(None)  # set by _finish_episodes: the episodes before are unknown
    columns["task_index"].append(spec.task_index)
    for name in ("time", "carrier_pos", "carrier_quat", "camera_pos", "camera_quat",
                 "camera_angvel", "camera_linvel", "threat_index", "threat_distance",
                 "threat_bearing", "threat_closing_speed", "threat_ttc", "collision",
                 "first_collision_frame", "ssim", "goal_reached"):
        columns[name].append(info[name])
    columns["goal_distance"].append(info.get("goal_distance", math.nan))
    columns["goal_bearing"].append(info.get("goal_bearing", math.nan))
    columns["observation.state"].append(obs["proprio"])
    columns["observation.goal"].append(obs.get("goal", nan3))
    columns["action"].append(np.full(2, np.nan, np.float32) if step.action is None
                             else step.action)
    columns["reward"].append(step.reward)
    columns["terminated"].append(step.terminated)
    columns["truncated"].append(step.truncated)


def _episode_meta(spec: EpisodeSpec, columns: Mapping[str, list], fps: float,
                  size: tuple[int, int]) -> dict[str, Any]:
    """Outcome, collision frame, closest approach and ISI of an episode's labels."""
    length = len(columns["frame_index"])
    hits = np.flatnonzero(columns["collision"])
    collision = int(hits[0]) if hits.size else None
    distance = np.asarray(columns["threat_distance"], np.float64)
    finite = np.isfinite(distance)
    closest = float(distance[finite].min()) if finite.any() else None
    closest_frame = int(np.flatnonzero(finite)[distance[finite].argmin()]) if finite.any() \
        else None
    if collision is not None:
        outcome = "collision"
    elif closest is not None and closest < layout.NEAR_MISS_DISTANCE:
        outcome = "near_miss"
    else:
        outcome = "clear"
    ssim = np.asarray(columns["ssim"][1:], np.float64)
    return {
        "episode_index": spec.index, "scenario": spec.scenario, "task_index": spec.task_index,
        "jitter": spec.jitter, "seed": spec.seed, "length": length, "fps": fps,
        "resolution": list(size), "collision_frame": collision, "outcome": outcome,
        "near_miss": outcome == "near_miss", "closest_approach": closest,
        "closest_approach_frame": closest_frame,
        "goal_reached": bool(any(columns["goal_reached"])),
        "isi": float(ssim.mean()) if ssim.size else None,
    }


def _parquet_bytes(columns: Mapping[str, list], spec: EpisodeSpec, meta: Mapping[str, Any]
                   ) -> bytes:
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = layout.label_schema(spec.models, spec.noise)
    table = pa.table({name: pa.array(columns[name], type=schema.field(name).type)
                      for name in schema.names}, schema=schema)
    table = table.replace_schema_metadata({layout.EPISODE_KEY: json.dumps(meta, sort_keys=True)})
    buf = io.BytesIO()
    pq.write_table(table, buf, compression="zstd")
    return buf.getvalue()


def _sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()
