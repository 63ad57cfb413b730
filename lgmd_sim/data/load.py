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
import os
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.data import layout

__all__ = ["Clip", "Dataset", "Episode", "detect_inputs", "episodes", "open_dataset"]

_EPISODE_SPEC = re.compile(r"(?P<path>.+):(?P<index>\d+)")


def _pa():
    from lgmd_sim.extras import require

    return require("pyarrow", "data"), require("pyarrow.parquet", "data")


class Episode:
    """One episode of a dataset: metadata now, labels and frames when asked for.

    Attributes:
        index: the episode index.
        meta: its row of the episode table (scenario, jitter, seed, length, outcome,
            collision_frame, closest_approach, isi, config...).
        video_path, data_path: its files.
    """

    def __init__(self, root: Path, meta: dict[str, Any], video: str):
        self.root = root
        self.meta = meta
        self.index: int = meta["episode_index"]
        self.video_path = root / layout.video_path(self.index, video)
        self.data_path = root / layout.data_path(self.index)

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
        _pa_mod, pq = _pa()
        return pq.read_table(self.data_path)

    def iter_frames(self, noise: str | None = None) -> Iterator[np.ndarray]:
        """The frames, (H, W, 3) uint8 RGB, in order; with `noise` (one of the dataset's
        variants, or any "kind:level[+kind:level]"), that noise on each, drawn from the
        episode's seed and the frame index: the frames the variant's labels were made on."""
        from lgmd_sim import noise as noise_mod
        from lgmd_sim.video import VideoReader

        noises = noise_mod.parse(noise.replace("+", ",")) if noise else []
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
        pa, pq = _pa()
        tables = [pq.read_table(ep.data_path, columns=columns) for ep in self]
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
    """Open the dataset in folder `path` (made by ``lgmd-sim dataset generate``)."""
    _pa_mod, pq = _pa()
    root = Path(path)
    if not (root / layout.INFO).is_file():
        what = ("its generation has not finished (run the same command again to resume)"
                if (root / layout.CONFIG).is_file() else "not an lgmd-sim dataset")
        raise ValueError(f"cannot open dataset {root}: no {layout.INFO}: {what}")
    try:
        info = json.loads((root / layout.INFO).read_text())
        config = json.loads((root / layout.CONFIG).read_text())
        episodes = pq.read_table(root / layout.EPISODES)
    except (OSError, ValueError) as exc:
        raise ValueError(f"cannot open dataset {root}: {exc}") from None
    return Dataset(root, info, config, episodes)


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
            out.append((os.path.join(ep.root, f"episode_{ep.index:06d}"), str(ep.video_path),
                        ep.collision_frame))
    return out
