"""Reading a dataset: episodes with frames (lazily) and labels, filters, a clip sampler.

>>> from lgmd_sim import data
>>> ds = data.open("my-dataset")                       # needs the 'data' extra (pyarrow)
>>> hits = ds.filter(scenario="HandheldApproach", jitter=1, outcome="collision")
>>> for ep in hits:                                    # one episode at a time
...     frames = ep.frames()                           # (T, H, W, 3) uint8, decoded now
...     ep.labels["threat_ttc"], ep.collision_frame, ep.meta["isi"]
>>> noisy = ep.frames(noise="gaussian:0.005")          # a noise variant, derived on load
>>> for clip in ds.clips(16, seed=0): clip.frames, clip.labels   # (16, H, W, 3) windows
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.core.fileio import json_kind, read_json
from lgmd_sim.data import layout

__all__ = ["Clip", "Dataset", "Episode", "detect_inputs", "episodes", "open_dataset",
           "read_meta_table"]

_EPISODE_SPEC = re.compile(r"(?P<path>.+):(?P<index>\d+)")


def _pa():
    from lgmd_sim.core.extras import require

    return require("pyarrow", "data"), require("pyarrow.parquet", "data")


class Episode:
    """One episode of a dataset: metadata now, labels and frames when asked for.

    Attributes:
        index: the episode index.
        meta: its row of the episode table (scenario, jitter, seed, length, outcome,
            collision_frame, closest_approach, isi, config...).
        video_path, data_path: its files.

    Its files are checked to be its own as they are read (`read_labels`, `iter_frames`):
    a swapped or copied file is refused, naming it, rather than served as this episode's.
    """

    def __init__(self, root: Path, meta: dict[str, Any], video: str):
        self.root = root
        self.meta = meta
        self.index: int = meta["episode_index"]
        self.video_path = root / layout.video_path(self.index, video)
        self.data_path = root / layout.data_path(self.index)
        self._video_checked: tuple[int, int, int] | None = None  # the file's, when checked

    def __repr__(self) -> str:
        m = self.meta
        return (f"Episode({self.index}, {m['scenario']}, jitter={m['jitter']:g}, "
                f"seed={m['seed']}, {m['length']} frames, {m['outcome']})")

    @property
    def scenario(self) -> str:
        return self.meta["scenario"]

    @property
    def jitter(self) -> float:
        return self.meta["jitter"]

    @property
    def seed(self) -> int:
        return self.meta["seed"]

    @property
    def length(self) -> int:
        return self.meta["length"]

    @property
    def fps(self) -> float:
        return self.meta["fps"]

    @property
    def outcome(self) -> str:
        return self.meta["outcome"]

    @property
    def collision_frame(self) -> int | None:
        return self.meta["collision_frame"]

    @property
    def labels(self):  # -> pyarrow.Table
        """The per-frame labels (a pyarrow Table; ``.to_pandas()`` with pandas)."""
        return self.read_labels()

    def read_labels(self, columns: Sequence[str] | None = None):  # -> pyarrow.Table
        """The labels, or those `columns` of them; refused (ValueError naming the file)
        unless the data file holds this episode's rows, every one: a swapped or copied
        file would otherwise pass for this episode's, unnoticed by anything but verify."""
        _pa_mod, pq = _pa()
        import pyarrow.compute as pc

        read = None if columns is None else list(dict.fromkeys(["episode_index", *columns]))
        try:
            table = pq.read_table(self.data_path, columns=read)
        except (OSError, ValueError) as exc:
            raise ValueError(f"{self.data_path}: cannot read episode {self.index}'s labels: "
                             f"{exc}") from None
        found = pc.min_max(table["episode_index"]).as_py()
        if table.num_rows and (found["min"], found["max"]) != (self.index, self.index):
            whose = (f"episode {found['min']}'s" if found["min"] == found["max"]
                     else f"episodes {found['min']} to {found['max']}'s")
            raise ValueError(f"{self.data_path}: holds {whose} labels, not episode "
                             f"{self.index}'s (a swapped or copied file? lgmd-sim dataset "
                             f"verify {self.root} checks every file)")
        if table.num_rows != self.length:
            raise ValueError(f"{self.data_path}: {table.num_rows} rows, episode {self.index} "
                             f"has {self.length} frames")
        return table if columns is None else table.select(list(columns))

    def check_video(self) -> None:
        """Refuse (ValueError naming the file) a video that is not this episode's.

        Nothing in a video names its episode and episodes of one length are common, so its
        SHA-256 is compared with the episode table's: a few percent of the cost of decoding
        it, paid once while the file stays as it was (its size, modification time and
        inode), not on every pass over the frames.
        """
        try:
            st = self.video_path.stat()
            if (st.st_size, st.st_mtime_ns, st.st_ino) == self._video_checked:
                return
            digest = layout.sha256(self.video_path)
        except OSError as exc:
            raise ValueError(f"{self.video_path}: cannot read episode {self.index}'s video: "
                             f"{exc.strerror or exc}") from None
        if digest != self.meta[layout.VIDEO_SHA256]:
            raise ValueError(f"{self.video_path}: not episode {self.index}'s video (its SHA-256 "
                             f"differs from the episode table's; lgmd-sim dataset verify "
                             f"{self.root} checks every file)")
        self._video_checked = (st.st_size, st.st_mtime_ns, st.st_ino)

    def iter_frames(self, noise: str | None = None) -> Iterator[np.ndarray]:
        """The frames, (H, W, 3) uint8 RGB, in order; with `noise` (one of the dataset's
        variants, or any "kind:level[+kind:level]"), that noise on each, drawn from the
        episode's seed and the frame index: the frames the variant's labels were made on."""
        from lgmd_sim.signals import noise as noise_mod
        from lgmd_sim.signals.video import VideoReader

        noises = noise_mod.parse(noise.replace("+", ",")) if noise else []
        self.check_video()
        for i, rgb in enumerate(VideoReader(self.video_path)):
            yield noise_mod.apply(rgb, noises, self.seed, i) if noises else rgb

    def frames(self, noise: str | None = None) -> np.ndarray:
        """Every frame as one (T, H, W, 3) uint8 array (see `iter_frames`)."""
        return np.stack(list(self.iter_frames(noise)))


@dataclass(frozen=True)
class Clip:
    """A window of an episode: `frames` (L, H, W, 3) and their `labels` (a pyarrow Table)."""

    episode: Episode
    start: int
    frames: np.ndarray
    labels: Any


class Dataset:
    """A dataset folder, or a filtered view of one; iterate it for its `Episode` s.

    Attributes:
        path: the folder.
        info: meta/info.json.
        config: meta/config.json (the generation configuration).
        episodes: the episode table of this view (a pyarrow Table).
    """

    def __init__(self, path: Path, info: dict[str, Any], config: dict[str, Any], episodes):
        self.path = path
        self.info = info
        self.config = config
        self.episodes = episodes
        self._metas = episodes.to_pylist()

    def __repr__(self) -> str:
        return f"Dataset('{self.path}', {len(self)} episodes)"

    def __len__(self) -> int:
        return len(self._metas)

    def __getitem__(self, i: int) -> Episode:
        """The `i`-th episode of this view."""
        return Episode(self.path, self._metas[i], self.config["video"])

    def __iter__(self) -> Iterator[Episode]:
        for i in range(len(self)):
            yield self[i]

    def episode(self, index: int) -> Episode:
        """The episode with episode index `index`."""
        for m in self._metas:
            if m["episode_index"] == index:
                return Episode(self.path, m, self.config["video"])
        raise ValueError(f"dataset {self.path}: no episode {index} (it has "
                         f"{self.info['total_episodes']}: 0..{self.info['total_episodes'] - 1})")

    @property
    def noise_variants(self) -> list[str]:
        return list(self.config["noise"])

    def filter(self, *, scenario: str | Sequence[str] | None = None,
               jitter: float | Sequence[float] | None = None,
               outcome: str | Sequence[str] | None = None) -> Dataset:
        """The episodes of the given scenarios, jitter levels and outcomes ("collision",
        "near_miss", "clear"); None keeps all."""
        pa, _pq = _pa()
        import pyarrow.compute as pc

        mask = pa.array([True] * len(self))
        for column, wanted in (("scenario", scenario), ("jitter", jitter),
                               ("outcome", outcome)):
            if wanted is None:
                continue
            values = [wanted] if isinstance(wanted, str | int | float) else list(wanted)
            if column == "outcome" and set(values) - set(layout.OUTCOMES):
                raise ValueError(f"unknown outcome(s) {sorted(set(values) - set(layout.OUTCOMES))}"
                                 f"; outcomes: {', '.join(layout.OUTCOMES)}")
            mask = pc.and_(mask, pc.is_in(self.episodes[column], pa.array(
                [float(v) for v in values] if column == "jitter" else values)))
        return Dataset(self.path, self.info, self.config, self.episodes.filter(mask))

    def labels(self, columns: Sequence[str] | None = None):  # -> pyarrow.Table
        """The labels of every episode of this view, one table (in episode order)."""
        pa, _pq = _pa()
        tables = [ep.read_labels(columns) for ep in self]
        return pa.concat_tables(tables) if tables else None

    def windows(self, length: int, stride: int = 1) -> list[tuple[int, int]]:
        """Every (position in this view, start frame) of a `length`-frame window, starts
        `stride` apart."""
        if length < 1 or stride < 1:
            raise ValueError(f"clip length and stride must be >= 1, got {length}, {stride}")
        return [(i, s) for i, m in enumerate(self._metas)
                for s in range(0, m["length"] - length + 1, stride)]

    def clips(self, length: int, *, stride: int = 1, shuffle: bool = True, seed: int = 0,
              noise: str | None = None) -> Iterator[Clip]:
        """The clip sampler: every `length`-frame window once (see `windows`).

        With `shuffle`, episodes come in a random order and each episode's windows in a
        random order, from `seed`; either way each episode is decoded once, so a pass
        costs one decode of the data. Mix across episodes with a shuffle buffer (or the
        PyTorch `lgmd_sim.data.torch.WindowDataset`) where a batch must span episodes.
        """
        rng = np.random.default_rng(seed)
        by_episode: dict[int, list[int]] = {}
        for i, s in self.windows(length, stride):
            by_episode.setdefault(i, []).append(s)
        order = list(by_episode)
        if shuffle:
            rng.shuffle(order)
        for i in order:
            ep = self[i]
            frames, labels = ep.frames(noise), ep.labels
            starts = by_episode[i]
            if shuffle:
                rng.shuffle(starts)
            for s in starts:
                yield Clip(ep, s, frames[s:s + length], labels.slice(s, length))


def open_dataset(path: str | os.PathLike) -> Dataset:
    """Open the dataset in folder `path` (made by ``lgmd-sim dataset generate``); a meta
    file of the wrong shape is refused with one line naming it."""
    root = Path(path)
    if not (root / layout.INFO).is_file():
        what = ("its generation has not finished (run the same command again to resume)"
                if (root / layout.CONFIG).is_file() else "not an lgmd-sim dataset")
        raise ValueError(f"cannot open dataset {root}: no {layout.INFO}: {what}")
    try:
        info = _check_info(root / layout.INFO, read_json(root / layout.INFO))
        config = _check_config(root / layout.CONFIG, read_json(root / layout.CONFIG))
        episodes = read_meta_table(root / layout.EPISODES, layout.EPISODE_COLUMNS)
    except ValueError as exc:
        raise ValueError(f"cannot open dataset {root}: {exc}") from None
    return Dataset(root, info, config, episodes)


def read_meta_table(path: Path, columns: Sequence[tuple[str, str]]):  # -> pyarrow.Table
    """A table of the dataset's meta folder, refused (ValueError naming it) unless it has
    the declared `columns` (name, `layout.arrow_type` name), of their types."""
    _pa_mod, pq = _pa()
    try:
        table = pq.read_table(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: cannot read it: {exc}") from None
    for name, kind in columns:
        want = layout.arrow_type(kind)
        if name not in table.column_names:
            raise ValueError(f"{path}: no column {name!r}")
        if table.schema.field(name).type != want:
            raise ValueError(f"{path}: column {name!r} is {table.schema.field(name).type}, "
                             f"not {want}")
    return table


def _check_info(path: Path, info: Any) -> dict[str, Any]:
    """info.json, with the keys the readers rely on, of their JSON types."""
    if not isinstance(info, dict):
        raise ValueError(f"{path}: holds {json_kind(type(info))}, not an object")
    for key, kind in layout.INFO_KEYS.items():
        if key not in info:
            raise ValueError(f"{path}: no {key!r} key")
        value = info[key]
        # JSON has one number type: an integral fps reads back as an int
        wanted = (int, float) if kind is float else kind
        if not isinstance(value, wanted) or isinstance(value, bool):
            raise ValueError(f"{path}: {key!r} is {json_kind(type(value))}, not "
                             f"{json_kind(kind)}")
        if isinstance(value, int | float) and (value < 0 or not math.isfinite(value)):
            raise ValueError(f"{path}: {key!r} is {value}, not a number >= 0")
    if info["fps"] <= 0:
        raise ValueError(f"{path}: 'fps' is {info['fps']}, not a positive number")
    camera = info["features"].get(layout.VIDEO_KEY)
    if not isinstance(camera, dict):
        raise ValueError(f"{path}: 'features' has no {layout.VIDEO_KEY!r} object")
    shape = camera.get("shape")
    if not (isinstance(shape, list) and len(shape) == 3 and all(
            isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in shape)):
        raise ValueError(f"{path}: the shape of {layout.VIDEO_KEY!r} is {json.dumps(shape)}, "
                         "not [height, width, channels] (3 positive integers)")
    return info


def _check_config(path: Path, config: Any) -> dict[str, Any]:
    """config.json, with what the loader reads of it: the video format, the noise
    variants (verify reads the rest)."""
    if not isinstance(config, dict):
        raise ValueError(f"{path}: holds {json_kind(type(config))}, not an object")
    if config.get("video") not in layout.VIDEO_FORMATS:
        raise ValueError(f"{path}: 'video' is {json.dumps(config.get('video'))}, not one of "
                         f"{', '.join(layout.VIDEO_FORMATS)}")
    noise = config.get("noise")
    if not isinstance(noise, list) or not all(isinstance(v, str) for v in noise):
        raise ValueError(f"{path}: 'noise' is {json.dumps(noise)}, not a list of noise "
                         "variants")
    return config


def episodes(spec: str | os.PathLike) -> list[Episode] | None:
    """The episodes `spec` names: every episode of a dataset folder, or episode N of
    ``DIR:N``; None when `spec` is neither (a video file, an image folder)."""
    text = os.fspath(spec)
    if layout.is_dataset(text):
        return list(open_dataset(text))
    match = _EPISODE_SPEC.fullmatch(text)
    if match and not Path(text).exists() and layout.is_dataset(match["path"]):
        return [open_dataset(match["path"]).episode(int(match["index"]))]
    return None


def detect_inputs(videos: Sequence[str]) -> list[tuple[str, str, int | None]]:
    """(name, video file, labelled collision frame) per input of ``lgmd-sim detect``: a
    dataset folder becomes each of its episodes, ``DIR:N`` its episode N (see `episodes`),
    with the collision frame from the labels; anything else stays as it is, unlabelled."""
    out: list[tuple[str, str, int | None]] = []
    for video in videos:
        found = episodes(video)
        if found is None:
            out.append((video, video, None))
        for ep in found or ():
            ep.check_video()  # detect reads the file itself
            out.append((os.path.join(ep.root, f"episode_{ep.index:06d}"), str(ep.video_path),
                        ep.collision_frame))
    return out
