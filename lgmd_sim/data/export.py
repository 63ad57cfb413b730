"""An export to LeRobot's own format.

`export` (``lgmd-sim dataset export SRC DEST --format lerobot``) writes a dataset as a
LeRobot v3.0 dataset that LeRobot's ``LeRobotDataset`` opens: the frames re-encoded as
MP4 in H.264 (or AV1, LeRobot's own default), which both of its decoders (torchcodec,
PyAV) read; the labels with their ``index`` column; the task table indexed by the task's
text, as LeRobot names a frame's task; stats.json with the camera's per-channel
statistics; a card whose ``configs:`` block makes ``datasets.load_dataset`` read the
labels. It is written into a hidden folder beside DEST, renamed to DEST when complete.

The export is lossy (the LGMD models respond to frame differences, which a lossy codec
changes): the source dataset stays the reference, the export is for LeRobot's tools.
"""

from __future__ import annotations

import errno
import json
import os
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.core.fileio import atomic_folder, canonical_json
from lgmd_sim.core.params import checked, one_of
from lgmd_sim.data import card, layout
from lgmd_sim.data.stats import feature_stats, image_stats

__all__ = ["CODECS", "FORMATS", "Codec", "ExportConfig", "ExportSummary", "export"]

#: The formats `export` writes.
FORMATS = ("lerobot",)
#: LeRobot's target file sizes (info.json), which its writer needs to append episodes.
DATA_FILES_SIZE_MB, VIDEO_FILES_SIZE_MB = 100, 200


@dataclass(frozen=True)
class Codec:
    """An export video codec: the FFmpeg encoder (through PyAV), the codec's name as
    info.json records it, and the encoder's options."""

    encoder: str
    name: str
    options: Mapping[str, str]
    doc: str


#: ``g=2`` as LeRobot encodes: a key frame every other frame, so that a training loader
#: that asks for random frames decodes at most one frame more. H.264 at CRF 18 is close
#: to transparent; AV1 gets LeRobot's own settings.
CODECS: dict[str, Codec] = {
    "h264": Codec("libx264", "h264", {"crf": "18", "g": "2"},
                  "H.264 (libx264, CRF 18): decoded everywhere, the default"),
    "av1": Codec("libsvtav1", "av1", {"crf": "30", "g": "2", "preset": "12"},
                 "AV1 (SVT-AV1, CRF 30): LeRobot's own default, smaller, slower to write"),
}
_PIX_FMT = "yuv420p"


@dataclass(frozen=True)
class ExportConfig:
    """An export: the dataset `source`, the new folder `dest`, the format and the codec.

    Raises:
        ValueError: `source` is not a dataset, `dest` exists or lies inside `source`, an
            unknown format or codec (one line naming it).
    """

    source: Path
    dest: Path
    format: str = "lerobot"
    codec: str = "h264"

    def __post_init__(self) -> None:
        object.__setattr__(self, "source", Path(self.source))
        object.__setattr__(self, "dest", Path(self.dest))
        checked("format", self.format, one_of(*FORMATS))
        checked("codec", self.codec, one_of(*CODECS))
        if not layout.is_dataset(self.source):
            raise ValueError(f"{self.source}: not an lgmd-sim dataset (no {layout.INFO})")
        if self.dest.exists():
            raise ValueError(f"{self.dest} exists: export into a new folder")
        if self.dest.resolve().is_relative_to(self.source.resolve()):
            raise ValueError(f"{self.dest} is inside the dataset {self.source}: export "
                             "elsewhere")


@dataclass(frozen=True)
class ExportSummary:
    """What an `export` call wrote."""

    path: Path
    episodes: int
    frames: int
    seconds: float
    codec: str


def export(config: ExportConfig) -> ExportSummary:
    """Write the dataset `config.source` in LeRobot's format to `config.dest`.

    Raises:
        ValueError: the source cannot be read (one line naming the file) or its frames do
            not suit the codec.
        OSError: a write error (a full disk), naming DEST; nothing is left under DEST.
        MissingExtra: PyAV or pyarrow is missing (the 'lerobot' extra).
    """
    from lgmd_sim.core.extras import require
    from lgmd_sim.data.load import open_dataset

    require("av", "lerobot")
    require("pyarrow", "lerobot")
    start = time.monotonic()
    ds = open_dataset(config.source)
    h, w = ds.info["features"][layout.VIDEO_KEY]["shape"][:2]
    if h % 2 or w % 2:
        raise ValueError(f"{config.source}: frames of {h}x{w}: {config.codec} in {_PIX_FMT} "
                         "needs an even height and width")
    dest = config.dest
    try:
        with atomic_folder(dest) as tmp:
            frames = _write(tmp, ds, config, (h, w))
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise OSError(f"no space left on the device of {dest}: nothing was exported"
                          ) from None
        raise OSError(f"cannot export to {dest}: {exc.strerror or exc}") from None
    return ExportSummary(dest, len(ds), frames, time.monotonic() - start, config.codec)


def _write(root: Path, ds: Any, config: ExportConfig, size: tuple[int, int]) -> int:
    """Write the export into the folder `root`; return its number of frames."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    codec = CODECS[config.codec]
    video_path = layout.VIDEO_PATH.replace("{suffix}", ".mp4")
    histogram = np.zeros((3, 256), np.int64)
    rows, tables, start = [], [], 0
    for ep in ds:
        labels = layout.with_index(ep.labels.replace_schema_metadata(None), start)
        data = root / layout.data_path(ep.index)
        chunk, file = divmod(ep.index, layout.CHUNK_SIZE)
        video = root / video_path.format(video_key=layout.VIDEO_KEY, chunk_index=chunk,
                                         file_index=file)
        for folder in (data.parent, video.parent):
            folder.mkdir(parents=True, exist_ok=True)
        pq.write_table(labels, data, compression="zstd")
        written = _encode(video, ep.iter_frames(), ep.fps, size, codec, histogram)
        if written != ep.length:
            raise ValueError(f"{ep.video_path}: {written} frames, episode {ep.index} has "
                             f"{ep.length}")
        rows.append({**ep.meta, "video_codec": codec.name,
                     "data/sha256": layout.sha256(data),
                     layout.VIDEO_SHA256: layout.sha256(video),
                     "dataset_from_index": start, "dataset_to_index": start + ep.length,
                     "meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0})
        tables.append(labels)
        start += ep.length
    schema = ds.episodes.schema.remove_metadata()
    schema = schema.append(pa.field("meta/episodes/chunk_index", pa.int64())).append(
        pa.field("meta/episodes/file_index", pa.int64()))
    episodes = root / layout.EPISODES
    episodes.parent.mkdir(parents=True)
    pq.write_table(pa.Table.from_pylist(rows, schema=schema), episodes, compression="zstd")
    pq.write_table(_tasks(pq.read_table(ds.path / layout.TASKS)), root / layout.TASKS)
    stats = {**feature_stats(pa.concat_tables(tables)),
             layout.VIDEO_KEY: image_stats(histogram, start)}
    (root / layout.STATS).write_text(canonical_json(stats))
    (root / layout.CARD).write_text(_card(config, [r["data/sha256"] for r in rows], start))
    info = _info(ds, config, video_path, tables[0].column_names)
    # Not canonical_json: LeRobot casts a subset of episodes to the features in info.json's
    # order, which must be the data files' column order, so not sorted.
    (root / layout.INFO).write_text(json.dumps(info, indent=4, allow_nan=False) + "\n")
    return start


def _encode(path: Path, frames: Iterable[np.ndarray], fps: float, size: tuple[int, int],
            codec: Codec, histogram: np.ndarray) -> int:
    """Encode RGB `frames` into the MP4 `path`, frame i at i / fps (LeRobot finds a frame
    by its timestamp), adding their pixels to `histogram`; return how many."""
    import av

    h, w = size
    count = 0
    os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1 prints ~20 lines per file otherwise
    try:
        with av.open(str(path), "w", format="mp4") as out:
            stream = out.add_stream(codec.encoder, rate=Fraction(fps).limit_denominator(1001),
                                    options=dict(codec.options))
            stream.width, stream.height, stream.pix_fmt = w, h, _PIX_FMT
            for rgb in frames:
                for channel in range(3):
                    histogram[channel] += np.bincount(rgb[..., channel].ravel(), minlength=256)
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
                frame.pts = count
                out.mux(stream.encode(frame))
                count += 1
            out.mux(stream.encode())
    except av.FFmpegError as exc:
        raise OSError(getattr(exc, "errno", None), f"cannot write {path}: {exc}") from None
    return count


def _tasks(source):  # -> pyarrow.Table
    """LeRobot's task table: the task's text as the (pandas) index, then task_index
    (LeRobot names a frame's task by ``tasks.iloc[task_index].name``), and our scenario."""
    import pyarrow as pa

    table = pa.table({"task_index": source["task_index"], "scenario": source["scenario"],
                      "task": source["task"]})
    pandas = {"index_columns": ["task"], "column_indexes": [], "columns": [
        {"name": name, "field_name": name, "pandas_type": pandas_type, "numpy_type": numpy_type,
         "metadata": None}
        for name, pandas_type, numpy_type in (("task_index", "int64", "int64"),
                                              ("scenario", "unicode", "object"),
                                              ("task", "unicode", "object"))]}
    return table.replace_schema_metadata({"pandas": json.dumps(pandas)})


def _info(ds: Any, config: ExportConfig, video_path: str, columns: list[str]
          ) -> dict[str, Any]:
    """The source's info.json for MP4 videos in `config.codec`, its features in the order
    of the data files' `columns`, with the ``index`` feature (which datasets made before
    it lack)."""
    import copy

    codec = CODECS[config.codec]
    info = copy.deepcopy(ds.info)
    index = {"dtype": "int64", "shape": [1], "names": None,
             "doc": "the frame's index in the whole dataset, as LeRobot"}
    features = {layout.VIDEO_KEY: info["features"][layout.VIDEO_KEY]} | {
        name: info["features"].get(name, index) for name in columns}
    features[layout.VIDEO_KEY]["info"].update({
        "video.codec": codec.name, "video.pix_fmt": _PIX_FMT, "video.lossless": False,
        "video.container": "mp4"})
    source_video = info["lgmd_sim"].get("video")
    info["lgmd_sim"].update(
        video=f"{config.codec}: {codec.doc}", lossless=False,
        exported_from={"dataset": config.source.name, "video": source_video,
                       "config": ds.config},
        files_per_episode="one data file and one video file per episode, as the source")
    info.update(features=features, video_path=video_path,
                data_files_size_in_mb=DATA_FILES_SIZE_MB,
                video_files_size_in_mb=VIDEO_FILES_SIZE_MB)
    return info


def _card(config: ExportConfig, data_sha256: list[str], frames: int) -> str:
    """The export's dataset card: the Hub's YAML header (the labels as the default
    configuration, as LeRobot's datasets have it, named after the label files' `data_sha256`
    as the source's card), what it is and how to open it."""
    name = config.dest.name
    episodes = len(data_sha256)
    return f"""---
{card.configs(data_sha256)}tags:
- LeRobot
- lgmd-sim
task_categories:
- robotics
---

# {name}

The lgmd-sim dataset `{config.source.name}` ({episodes} episodes, {frames} frames) in
LeRobot's dataset format v3.0, written by
`lgmd-sim dataset export {config.source.name} {name} --format {config.format} --codec
{config.codec}`. The frames are {CODECS[config.codec].doc} in MP4: lossy, so frame
differences are not exact; the source dataset holds them losslessly. The labels, their
units and meanings are in `meta/info.json` (`features`), their statistics in
`meta/stats.json`.

```python
from lerobot.datasets.lerobot_dataset import LeRobotDataset

ds = LeRobotDataset("local/{name}", root="{name}")
frame = ds[0]  # observation.images.camera (3, H, W) float in [0, 1], and every label
```
"""
