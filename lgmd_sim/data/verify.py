"""`lgmd-sim dataset verify DIR`: is the dataset complete and consistent?

Checks the shape of the meta files, the counts (every episode of the configuration, once),
the task table, the checksums of every data and video file, that every file belongs to
the dataset, and the labels of each episode:
row count and frame count against the episode's length, frame indices 0..T-1, strictly
increasing time and timestamps, the collision frame against the collision flags, the
outcome against both. Each problem is one line naming the file or the episode.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.data import layout

__all__ = ["verify"]


def verify(path: str | Path) -> tuple[list[str], dict[str, int]]:
    """The problems of the dataset in `path` (empty when it is sound) and its counts."""
    from lgmd_sim.data.load import open_dataset, read_meta_table

    root = Path(path)
    try:
        ds = open_dataset(root)
    except ValueError as exc:
        return [str(exc)], {}
    try:
        config = _config(ds.config)
    except KeyError as exc:
        return [f"{root / layout.CONFIG}: no {exc} key"], {}
    except (TypeError, ValueError) as exc:
        return [f"{root / layout.CONFIG}: {exc}"], {}
    problems: list[str] = []
    specs = config.specs()
    metas = ds.episodes.to_pylist()
    got = [(m["episode_index"], m["scenario"], m["jitter"], m["seed"]) for m in metas]
    want = [(s.index, s.scenario, s.jitter, s.seed) for s in specs]
    if got != want:
        missing = sorted(set(want) - set(got))
        extra = sorted(set(got) - set(want))
        problems.append(f"{root / layout.EPISODES}: the episode table does not match the "
                        f"configuration ({len(got)} episodes, {len(want)} expected"
                        + (f"; missing {_name(missing[0])}" if missing else "")
                        + (f"; unexpected {_name(extra[0])}" if extra else "") + ")")
    if ds.info.get("total_episodes") != len(metas):
        problems.append(f"{root / layout.INFO}: total_episodes is "
                        f"{ds.info.get('total_episodes')}, the episode table has {len(metas)}")
    frames = sum(m["length"] for m in metas)
    if ds.info.get("total_frames") != frames:
        problems.append(f"{root / layout.INFO}: total_frames is {ds.info.get('total_frames')}, "
                        f"the episodes have {frames}")
    try:
        tasks = read_meta_table(root / layout.TASKS, layout.TASK_COLUMNS)
    except ValueError as exc:
        problems.append(str(exc))
    else:
        if (tasks["scenario"].to_pylist() != list(config.scenarios)
                or tasks["task_index"].to_pylist() != list(range(len(config.scenarios)))):
            problems.append(f"{root / layout.TASKS}: the tasks are not the configuration's "
                            "scenarios, in order")
    expected_files = {layout.INFO, layout.CONFIG, layout.TASKS, layout.EPISODES,
                      layout.STATS, layout.CONTACT_SHEET, layout.CARD, layout.RUNS}
    for m in metas:
        expected_files |= {layout.data_path(m["episode_index"]),
                           layout.video_path(m["episode_index"], config.video)}
        problems += _check_episode(root, m, config.video, ds.info["fps"])
    for f in sorted(p for p in root.rglob("*") if p.is_file()):
        rel = f.relative_to(root).as_posix()
        if rel not in expected_files:
            kind = "a partial file left by a killed run" if ".partial" in f.name else \
                "a file that is not part of the dataset"
            problems.append(f"{f}: {kind}")
    for rel in sorted(expected_files - {layout.RUNS}):
        if not (root / rel).is_file() and not rel.startswith(("data/", "videos/")):
            problems.append(f"{root / rel}: missing")
    return problems, {"episodes": len(metas), "frames": frames}


def _config(cfg: dict[str, Any]):  # -> GenerateConfig
    """The generation configuration of config.json (KeyError, TypeError or ValueError
    where it is not one)."""
    from lgmd_sim.data.generate import GenerateConfig

    return GenerateConfig(
        tuple(cfg["scenarios"]), tuple(cfg["jitter"]), cfg["episodes"],
        cfg["resolution"] if isinstance(cfg["resolution"], str) else tuple(cfg["resolution"]),
        cfg["controller"], tuple(cfg["models"]), tuple(cfg["noise"]), cfg["video"], cfg["seed"],
        cfg["overrides"])


def _name(key: tuple) -> str:
    index, scenario, jitter, seed = key
    return f"episode {index} ({scenario}, jitter {jitter:g}, seed {seed})"


def _check_episode(root: Path, m: dict[str, Any], video: str, fps: float) -> list[str]:
    import cv2
    import pyarrow.parquet as pq

    index = m["episode_index"]
    name = _name((index, m["scenario"], m["jitter"], m["seed"]))
    data, vid = root / layout.data_path(index), root / layout.video_path(index, video)
    out = []
    for path, wanted in ((data, m["data/sha256"]), (vid, m[layout.VIDEO_SHA256])):
        if not path.is_file():
            out.append(f"{path}: missing ({name})")
        elif layout.sha256(path) != wanted:
            out.append(f"{path}: checksum differs from the episode table ({name})")
    if out:
        return out
    cap = cv2.VideoCapture(str(vid))
    count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    size = (int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)))
    cap.release()
    if count != m["length"]:
        out.append(f"{vid}: {count} frames, the episode has {m['length']} ({name})")
    if size != (m["height"], m["width"]):
        out.append(f"{vid}: frames are {size[0]}x{size[1]}, the dataset's "
                   f"{m['height']}x{m['width']} ({name})")
    t = pq.read_table(data)
    labels = {c: t[c].to_numpy(zero_copy_only=False) for c in (
        "episode_index", "frame_index", "timestamp", "time", "collision",
        "first_collision_frame")}
    n = t.num_rows
    if n != m["length"]:
        out.append(f"{data}: {n} rows, the episode has {m['length']} frames ({name})")
    if not (labels["episode_index"] == index).all():
        out.append(f"{data}: episode_index is not {index} on every row ({name})")
    if not np.array_equal(labels["frame_index"], np.arange(n)):
        out.append(f"{data}: frame_index is not 0..{n - 1} ({name})")
    if not np.allclose(labels["timestamp"], np.arange(n) / fps, rtol=0, atol=1e-4):
        out.append(f"{data}: timestamp is not frame_index / fps ({name})")
    for col in ("time", "timestamp"):
        bad = np.flatnonzero(np.diff(labels[col]) <= 0)
        if bad.size:
            out.append(f"{data}: {col} does not increase at frame {bad[0] + 1} ({name})")
    hits = np.flatnonzero(labels["collision"])
    first = int(hits[0]) if hits.size else None
    if first != m["collision_frame"]:
        out.append(f"{data}: the episode's collision frame is {m['collision_frame']}, the "
                   f"collision flag first rises at {first} ({name})")
    running = np.maximum.accumulate(np.where(labels["collision"], np.arange(n), -1))
    expected = np.where(running >= 0, first if first is not None else -1, -1)
    if not np.array_equal(labels["first_collision_frame"], expected):
        out.append(f"{data}: first_collision_frame disagrees with the collision flags "
                   f"({name})")
    near = (m["closest_approach"] is not None and not math.isnan(m["closest_approach"])
            and m["closest_approach"] < layout.NEAR_MISS_DISTANCE)
    outcome = "collision" if first is not None else "near_miss" if near else "clear"
    if outcome != m["outcome"]:
        out.append(f"{layout.EPISODES}: {name} is marked {m['outcome']}, its labels say "
                   f"{outcome}")
    meta = json.loads((pq.read_metadata(data).metadata or {}).get(layout.EPISODE_KEY, b"{}"))
    if meta.get("video_sha256") != m[layout.VIDEO_SHA256]:
        out.append(f"{data}: names another video checksum than the episode table ({name})")
    return out
