"""The manifest of a finished dataset: the episode and task tables, the card, the contact
sheet and meta/info.json, written as one set once every episode is complete (info.json
moved into place last)."""

from __future__ import annotations

import io
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from lgmd_sim.core.fileio import canonical_json, write_files
from lgmd_sim.data import layout

__all__ = ["episode_table", "info", "write_manifest"]


def episode_table(out: Path, metas: Sequence[Mapping[str, Any]]):  # -> pa.Table
    """One row per episode, in LeRobot's episode-table form plus this dataset's labels of
    the episode (outcome, collision frame, ISI...) and the checksums of its files."""
    import pyarrow as pa

    video_col = layout.VIDEO_COLUMNS
    rows: dict[str, list] = {name: [] for name, _type in layout.EPISODE_COLUMNS}
    start = 0
    for m in metas:
        chunk, file = divmod(m["episode_index"], layout.CHUNK_SIZE)
        for key in ("episode_index", "length", "scenario", "task_index", "jitter", "seed",
                    "outcome", "collision_frame", "near_miss", "closest_approach",
                    "closest_approach_frame", "goal_reached", "isi", "fps", "version",
                    "video_codec"):
            rows[key].append(m[key])
        rows["tasks"].append([m["scenario"]])
        rows["height"].append(m["resolution"][0])
        rows["width"].append(m["resolution"][1])
        rows["config"].append(json.dumps(m["config"], sort_keys=True))
        rows["data/chunk_index"].append(chunk)
        rows["data/file_index"].append(file)
        rows["data/sha256"].append(layout.sha256(out / layout.data_path(m["episode_index"])))
        rows["dataset_from_index"].append(start)
        rows["dataset_to_index"].append(start + m["length"])
        rows[f"{video_col}/chunk_index"].append(chunk)
        rows[f"{video_col}/file_index"].append(file)
        rows[f"{video_col}/from_timestamp"].append(0.0)
        rows[f"{video_col}/to_timestamp"].append(m["length"] / m["fps"])
        rows[layout.VIDEO_SHA256].append(m["video_sha256"])
        start += m["length"]
    return pa.table({name: pa.array(rows[name], type=layout.arrow_type(kind))
                     for name, kind in layout.EPISODE_COLUMNS})


def info(config_json: Mapping[str, Any], metas: Sequence[Mapping[str, Any]],
         scenarios: Sequence[str], video: str) -> dict[str, Any]:
    """meta/info.json: LeRobot's keys (fps, features, totals, paths), and ours under
    "lgmd_sim"."""
    first = metas[0]
    fmt = layout.VIDEO_FORMATS[video]
    models, noise = config_json["models"], config_json["noise"]
    return {
        "codebase_version": layout.CODEBASE_VERSION,
        "robot_type": "lgmd_sim",
        "total_episodes": len(metas),
        "total_frames": sum(m["length"] for m in metas),
        "total_tasks": len(scenarios),
        "chunks_size": layout.CHUNK_SIZE,
        "fps": first["fps"],
        "splits": {"train": f"0:{len(metas)}"},
        "data_path": layout.DATA_PATH,
        "video_path": layout.VIDEO_PATH.replace("{suffix}", fmt.suffix),
        "features": layout.features(models, noise, first["resolution"], first["fps"], video),
        "lgmd_sim": {
            "version": config_json["version"],
            "files_per_episode": "one data file and one video file per episode",
            "video": f"{video}: {fmt.doc}", "lossless": fmt.lossless,
            "models": models,
            "noise_variants": noise,
            "noise_views": "noisy frames are not stored: lgmd_sim.data derives them from "
                           "the clean frames (lgmd_sim.signals.noise.apply with the episode's seed "
                           "and the frame index)",
            "near_miss_distance": layout.NEAR_MISS_DISTANCE,
            "outcomes": list(layout.OUTCOMES),
            "identity": f"every file but {layout.RUNS}",
        },
    }


def _parquet(table) -> bytes:
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(table, buf, compression="zstd")
    return buf.getvalue()


def write_manifest(out: Path, config: Any, metas: Sequence[Mapping[str, Any]]) -> None:
    """Write the manifest of the dataset in `out` (every episode complete), as one set."""
    import pyarrow as pa

    from lgmd_sim.data import card
    from lgmd_sim.envs.catalogue import scenario

    config_json = config.as_json()
    episodes = episode_table(out, metas)
    values = {"task_index": list(range(len(config.scenarios))),
              "task": [f"{s}: {scenario(s).description}" for s in config.scenarios],
              "scenario": list(config.scenarios)}
    tasks = pa.table({name: pa.array(values[name], type=layout.arrow_type(kind))
                      for name, kind in layout.TASK_COLUMNS})
    meta_info = info(config_json, metas, config.scenarios, config.video)
    sheet = card.contact_sheet(out, config, metas)
    text = card.card(config, episodes, meta_info)
    write_files({  # info.json last: its presence marks a finished dataset
        out / layout.CONTACT_SHEET: lambda tmp: tmp.write_bytes(sheet),
        out / layout.CARD: lambda tmp: tmp.write_text(text),
        out / layout.TASKS: lambda tmp: tmp.write_bytes(_parquet(tasks)),
        out / layout.EPISODES: lambda tmp: tmp.write_bytes(_parquet(episodes)),
        out / layout.INFO: lambda tmp: tmp.write_text(canonical_json(meta_info)),
    })
