"""Where everything of a dataset lives, and the per-frame label schema.

The layout follows the LeRobot dataset v3 conventions where they fit (see
docs/guides/datasets.md)::

    DIR/README.md                                         the dataset card
    DIR/meta/info.json                                    fps, feature schema, totals, paths
    DIR/meta/config.json                                  the generation configuration
    DIR/meta/tasks.parquet                                one task per scenario
    DIR/meta/episodes/chunk-000/file-000.parquet          one row per episode
    DIR/meta/stats.json                                   per-feature statistics
    DIR/meta/contact_sheet.png                            a frame per scenario and jitter
    DIR/meta/run.json                                     run record (not part of the identity)
    DIR/data/chunk-000/file-000.parquet                   labels of episode 0, a row a frame
    DIR/videos/observation.images.camera/chunk-000/file-000.avi   its frames

Episode ``i`` is file ``i % CHUNK_SIZE`` of chunk ``i // CHUNK_SIZE``: one file per episode,
so that each episode is written (and resumed) on its own.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

#: The LeRobot format version whose layout this one follows.
CODEBASE_VERSION = "v3.0"
#: Episode files per chunk folder (LeRobot's default).
CHUNK_SIZE = 1000
#: The camera stream's feature name, as LeRobot names camera streams.
VIDEO_KEY = "observation.images.camera"
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
#: Every data file: the glob of `DATA_PATH` (the dataset cards' ``data_files``).
DATA_GLOB = re.sub(r"{[^}]*}", "*", DATA_PATH)
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}{suffix}"
INFO = "meta/info.json"
CONFIG = "meta/config.json"
TASKS = "meta/tasks.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"
CONTACT_SHEET = "meta/contact_sheet.png"
CARD = "README.md"
#: Per-feature statistics, as LeRobot's.
STATS = "meta/stats.json"
#: Facts of each run (wall time, workers, the command as typed): excluded from the
#: dataset's identity, the checksums and `verify`.
RUNS = "meta/run.json"
#: Key of the episode's metadata (JSON) in its data file's Parquet key-value metadata.
EPISODE_KEY = b"lgmd_sim.episode"
#: Prefix of the episode table's columns about the camera stream's files (LeRobot's names).
VIDEO_COLUMNS = f"videos/{VIDEO_KEY}"
#: The episode table's column of each episode's video checksum.
VIDEO_SHA256 = f"{VIDEO_COLUMNS}/sha256"
#: The episode table's columns, in order, and their types (see `arrow_type`): LeRobot's,
#: this dataset's labels of each episode and the checksums of its files.
EPISODE_COLUMNS: list[tuple[str, str]] = [
    ("episode_index", "int64"), ("tasks", "string[]"), ("length", "int64"),
    ("scenario", "string"), ("task_index", "int64"), ("jitter", "float64"),
    ("seed", "int64"), ("outcome", "string"), ("collision_frame", "int64"),
    ("near_miss", "bool"), ("closest_approach", "float64"),
    ("closest_approach_frame", "int64"), ("goal_reached", "bool"), ("isi", "float64"),
    ("fps", "float64"), ("height", "int64"), ("width", "int64"), ("version", "string"),
    ("video_codec", "string"), ("config", "string"), ("data/chunk_index", "int64"),
    ("data/file_index", "int64"), ("data/sha256", "string"), ("dataset_from_index", "int64"),
    ("dataset_to_index", "int64"), (f"{VIDEO_COLUMNS}/chunk_index", "int64"),
    (f"{VIDEO_COLUMNS}/file_index", "int64"), (f"{VIDEO_COLUMNS}/from_timestamp", "float64"),
    (f"{VIDEO_COLUMNS}/to_timestamp", "float64"), (VIDEO_SHA256, "string"),
]
#: The task table's columns and their types.
TASK_COLUMNS: list[tuple[str, str]] = [("task_index", "int64"), ("task", "string"),
                                       ("scenario", "string")]
#: meta/info.json's keys that readers rely on, and the JSON types of their values.
INFO_KEYS: dict[str, type] = {
    "codebase_version": str, "total_episodes": int, "total_frames": int, "total_tasks": int,
    "chunks_size": int, "fps": float, "splits": dict, "data_path": str,
    "video_path": str, "features": dict, "lgmd_sim": dict,
}

@dataclass(frozen=True)
class VideoFormat:
    """How an episode's frames are stored: container suffix, OpenCV fourcc, FFmpeg codec
    and pixel format (as info.json records them), and whether the frames come back exact."""

    suffix: str
    fourcc: str
    codec: str
    pix_fmt: str
    lossless: bool
    doc: str


#: The frame storage formats (``--video``). All in containers OpenCV and FFmpeg read; the
#: AVI files are byte-identical from run to run (FFmpeg's Matroska muxer writes a random
#: segment id, so .mkv files would differ every time).
VIDEO_FORMATS: dict[str, VideoFormat] = {
    "huffyuv": VideoFormat(".avi", "HFYU", "huffyuv", "rgb24", True,
                           "HuffYUV in AVI: lossless, fast to write (the default)"),
    "ffv1": VideoFormat(".avi", "FFV1", "ffv1", "bgr0", True,
                        "FFV1 in AVI: lossless, about half HuffYUV's size, but as slow to "
                        "write as the world is to render"),
    "mpeg4": VideoFormat(".mp4", "mp4v", "mpeg4", "yuv420p", False,
                         "MPEG-4 Part 2 in MP4: lossy (frame differences are not exact), "
                         "small"),
}
DEFAULT_VIDEO = "huffyuv"

#: A run with no collision whose closest approach is within this distance (m) of the
#: carrier is a near miss; farther, the episode is "clear".
NEAR_MISS_DISTANCE = 2.0
OUTCOMES = ("collision", "near_miss", "clear")

#: Names of the vector label columns' components.
VECTOR_NAMES: dict[str, list[str]] = {
    "carrier_pos": ["x", "y", "z"],
    "carrier_quat": ["w", "x", "y", "z"],
    "camera_pos": ["x", "y", "z"],
    "camera_quat": ["w", "x", "y", "z"],
    "camera_angvel": ["x", "y", "z"],
    "camera_linvel": ["x", "y", "z"],
    "observation.state": ["wheel_left", "wheel_right", "gyro_x", "gyro_y", "gyro_z",
                          "accel_x", "accel_y", "accel_z", "imu_rotation_x",
                          "imu_rotation_y", "imu_rotation_z"],
    "observation.goal": ["distance", "sin_bearing", "cos_bearing"],
    "action": ["v", "omega"],
}

class Column(NamedTuple):
    """A per-frame label column: `type` a pyarrow type name ("float64", "float32[3]" for
    a fixed-size list), `unit` "" where the value has none."""

    name: str
    type: str
    unit: str
    doc: str


#: Every per-frame column but the models', in order: the one declaration the label
#: schema, info.json's features and the dataset card are made from.
COLUMNS: list[Column] = [Column(*c) for c in (
    ("episode_index", "int64", "", "the episode"),
    ("frame_index", "int64", "", "the frame within its episode, from 0"),
    ("timestamp", "float32", "s", "frame_index / fps, as LeRobot"),
    ("index", "int64", "", "the frame's index in the whole dataset (the episodes in order, "
     "from 0), as LeRobot"),
    ("task_index", "int64", "", "the scenario (meta/tasks.parquet)"),
    ("time", "float64", "s", "simulated time"),
    ("carrier_pos", "float64[3]", "m", "carrier position (world frame)"),
    ("carrier_quat", "float64[4]", "", "carrier orientation (quaternion w, x, y, z)"),
    ("camera_pos", "float64[3]", "m", "camera position (world frame)"),
    ("camera_quat", "float64[4]", "", "camera orientation (quaternion w, x, y, z)"),
    ("camera_angvel", "float64[3]", "rad/s", "camera angular velocity (camera frame: x "
     "right, y up, z backwards)"),
    ("camera_linvel", "float64[3]", "m/s", "camera linear velocity (camera frame)"),
    ("threat_index", "int64", "", "the most threatening: static obstacles 0..n-1, then "
     "the arena walls (front, back, left, right), then the mover (-1: none)"),
    ("threat_distance", "float64", "m", "its surface distance from the carrier"),
    ("threat_bearing", "float64", "rad", "its bearing from the camera heading (left +)"),
    ("threat_closing_speed", "float64", "m/s", "its closing speed (approaching +)"),
    ("threat_ttc", "float64", "s", "its time to collision (inf when not closing)"),
    ("collision", "bool", "", "the carrier touches an obstacle on this frame"),
    ("first_collision_frame", "int64", "", "the first collision frame so far (-1: none "
     "yet)"),
    ("ssim", "float64", "", "SSIM with the previous frame (NaN on frame 0)"),
    ("goal_distance", "float64", "m", "distance to the goal (NaN without a goal)"),
    ("goal_bearing", "float64", "rad", "bearing of the goal (NaN without a goal)"),
    ("goal_reached", "bool", "", "the goal is reached on this frame"),
    ("observation.state", "float32[11]", "rad/s, m/s^2, rad", "proprioception: wheel "
     "speeds (rad/s), gyro (rad/s), accelerometer (m/s^2), the IMU's camera rotation since "
     "the last frame (rad)"),
    ("observation.goal", "float32[3]", "m, 1, 1", "goal observation: distance, sine and "
     "cosine of the bearing (NaN without a goal)"),
    ("action", "float32[2]", "", "the controller's action (v, omega), each in [-1, 1] of "
     "the carrier's max_speed and max_turn, on seeing this frame (NaN on the last frame)"),
    ("reward", "float64", "", "reward of the step that led to this frame (0 on frame 0)"),
    ("terminated", "bool", "", "the episode ended at this frame (collision or goal)"),
    ("truncated", "bool", "", "the episode was cut at this frame (time limit)"),
)]


def model_columns(model: str, variant: str | None = None) -> tuple[str, str]:
    """The potential and alarm columns of a model on the clean frames or a noise variant."""
    tail = "" if variant is None else f"[{variant}]"
    return f"{model}.potential{tail}", f"{model}.alarm{tail}"


def columns(models: Sequence[str], variants: Sequence[str]) -> list[Column]:
    """Every per-frame column: `COLUMNS`, then each model's potential and alarm on the
    clean frames and on each noise variant."""
    out = list(COLUMNS)
    for variant in [None, *variants]:
        on = "clean frames" if variant is None else f"frames with noise {variant}"
        for model in models:
            potential, alarm = model_columns(model, variant)
            out += [Column(potential, "float64", "", f"{model} membrane potential on the {on}"),
                    Column(alarm, "bool", "",
                           f"{model} alarm (potential above its threshold) on the {on}")]
    return out


def label_schema(models: Sequence[str], variants: Sequence[str]):  # -> pyarrow.Schema
    """The per-frame schema (see `columns`)."""
    import pyarrow as pa

    return pa.schema([pa.field(c.name, arrow_type(c.type)) for c in columns(models, variants)])


def with_index(labels, start: int):  # -> pyarrow.Table
    """An episode's `labels` (a pyarrow Table) with its ``index`` column, from `start`
    (its first frame's index in the whole dataset); added after ``timestamp``, where
    `COLUMNS` has it, to the labels of a dataset made before it."""
    import numpy as np
    import pyarrow as pa

    index = pa.array(np.arange(start, start + labels.num_rows), pa.int64())
    if "index" in labels.column_names:
        return labels.set_column(labels.schema.get_field_index("index"), "index", index)
    return labels.add_column(labels.schema.get_field_index("timestamp") + 1, "index", index)


def arrow_type(kind: str):  # -> pyarrow.DataType
    """The pyarrow type of a type name: "float64", "float32[3]" (a fixed-size list),
    "string[]" (a list of any length)."""
    import pyarrow as pa

    base, _, size = kind.partition("[")
    scalar = {"int64": pa.int64(), "float32": pa.float32(), "float64": pa.float64(),
              "bool": pa.bool_(), "string": pa.string()}[base]
    if not size:
        return scalar
    return pa.list_(scalar, int(size[:-1])) if size[:-1] else pa.list_(scalar)


def features(models: Sequence[str], variants: Sequence[str], size: Sequence[int],
             fps: float, video_format: str) -> dict[str, dict[str, Any]]:
    """info.json's feature schema, in LeRobot's form (dtype, shape, names), with each
    column's unit and meaning."""
    fmt = VIDEO_FORMATS[video_format]
    h, w = size
    out: dict[str, dict[str, Any]] = {VIDEO_KEY: {
        "dtype": "video", "shape": [h, w, 3], "names": ["height", "width", "channels"],
        "info": {"video.height": h, "video.width": w, "video.codec": fmt.codec,
                 "video.pix_fmt": fmt.pix_fmt, "video.fps": fps, "video.channels": 3,
                 "video.is_depth_map": False, "video.lossless": fmt.lossless,
                 "video.container": fmt.suffix[1:], "has_audio": False}}}
    for c in columns(models, variants):
        base, _, n = c.type.partition("[")
        out[c.name] = {"dtype": base, "shape": [int(n[:-1]) if n else 1],
                       "names": VECTOR_NAMES.get(c.name), "unit": c.unit or None,
                       "doc": c.doc}
    return out


def data_path(episode: int) -> str:
    chunk, file = divmod(episode, CHUNK_SIZE)
    return DATA_PATH.format(chunk_index=chunk, file_index=file)


def video_path(episode: int, video_format: str) -> str:
    chunk, file = divmod(episode, CHUNK_SIZE)
    return VIDEO_PATH.format(video_key=VIDEO_KEY, chunk_index=chunk, file_index=file,
                             suffix=VIDEO_FORMATS[video_format].suffix)


def sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a file, in hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            digest.update(block)
    return digest.hexdigest()


def is_dataset(path: str | os.PathLike) -> bool:
    """Whether `path` is a dataset folder (it has meta/info.json or meta/config.json)."""
    p = Path(path)
    return (p / INFO).is_file() or (p / CONFIG).is_file()
