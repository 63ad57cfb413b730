"""The dataset card (README.md of a dataset) and its contact sheet.

Both depend only on the dataset's files, so they are as reproducible as the episodes.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from lgmd_sim.data import layout

__all__ = ["card", "configs", "contact_sheet", "sheet_frame"]

#: Width of a contact-sheet tile (pixels); frames are scaled to it.
TILE_WIDTH = 240
#: ISI histogram bin width.
ISI_BIN = 0.05
#: Hex digits of the label files' digest in the configuration's name (64 bits).
CONFIG_DIGEST = 16


def configs(data_sha256: Sequence[str]) -> str:
    """A card's YAML ``configs:`` block: the label files as the one (default) configuration,
    named ``labels-`` and a digest of their SHA-256s (`data_sha256`, in episode order).

    Hugging Face `datasets` (``load_dataset("DIR")``, and the Hub for an upload of the
    folder) reads the per-frame labels and nothing else; without the block it would take the
    episode and task tables for data too. The name is the dataset's own because `datasets`
    keys its cache of ``load_dataset("DIR")`` on the folder's name and this block, not on
    the files: under a fixed name, a different dataset in a folder of the same name would
    be served the rows cached for the first."""
    digest = hashlib.sha256("\n".join(data_sha256).encode()).hexdigest()[:CONFIG_DIGEST]
    return f"""configs:
- config_name: labels-{digest}
  default: true
  data_files:
  - split: train
    path: {layout.DATA_GLOB}
"""


def sheet_frame(meta: Mapping[str, Any]) -> int:
    """The frame a contact sheet shows of an episode: 0.5 s before the collision, else
    before the closest approach (then a passing object is still in view), else the
    middle frame."""
    key = meta["collision_frame"]
    if key is None:
        key = meta["closest_approach_frame"]
    if key is None:
        return meta["length"] // 2
    return max(0, key - round(meta["fps"] / 2))


def _frame(path: Path, index: int) -> np.ndarray:
    from lgmd_sim.signals.video import VideoReader

    for i, rgb in enumerate(VideoReader(path)):
        if i == index:
            return rgb
    raise ValueError(f"{path}: has no frame {index}")


def _tile(rgb: np.ndarray, label: str) -> np.ndarray:
    h, w = rgb.shape[:2]
    size = (TILE_WIDTH, round(h * TILE_WIDTH / w))
    tile = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA if w > TILE_WIDTH
                      else cv2.INTER_NEAREST)
    banner = np.zeros((18, TILE_WIDTH, 3), np.uint8)  # the label on black, above the frame
    cv2.putText(banner, label, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                cv2.LINE_AA)
    return np.vstack([banner, tile])


def contact_sheet(out: Path, config: Any, metas: Sequence[Mapping[str, Any]]) -> bytes:
    """A PNG: a row per scenario, a column per jitter level (the first seed's episode),
    then the noise variants of the last jitter level's frame."""
    from lgmd_sim.signals import noise

    by_key = {(m["scenario"], m["jitter"], m["seed"]): m for m in metas}
    rows = []
    for name in config.scenarios:
        tiles = []
        for jitter in config.jitter:
            m = by_key[(name, jitter, config.seed)]
            k = sheet_frame(m)
            rgb = _frame(out / layout.video_path(m["episode_index"], config.video), k)
            tiles.append(_tile(rgb, f"{name} j{jitter:g} f{k}"))
        for variant in config.noise:
            noisy = noise.apply(rgb, noise.parse(variant.replace("+", ",")), m["seed"], k)
            tiles.append(_tile(noisy, f"j{jitter:g} + {variant}"))
        rows.append(np.hstack(tiles))
    sheet = np.vstack(rows)
    ok, png = cv2.imencode(".png", cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    if not ok:
        raise ValueError("cannot encode the contact sheet")
    return png.tobytes()


def _counts(table) -> list[dict[str, Any]]:
    """Per (scenario, jitter): episodes, frames, outcomes, ISI mean and range."""
    groups: dict[tuple[str, float], list[dict[str, Any]]] = {}
    for row in table.to_pylist():
        groups.setdefault((row["scenario"], row["jitter"]), []).append(row)
    out = []
    for (name, jitter), rows in groups.items():
        isi = [r["isi"] for r in rows if r["isi"] is not None]
        out.append({"scenario": name, "jitter": jitter, "episodes": len(rows),
                    "frames": sum(r["length"] for r in rows),
                    **{o: sum(r["outcome"] == o for r in rows) for o in layout.OUTCOMES},
                    "isi": isi})
    return out


def card(config: Any, episodes, info: Mapping[str, Any]) -> str:
    """The dataset card: what it holds, counts, balance, ISI, how it was made."""
    rows = episodes.to_pylist()
    total = len(rows)
    h, w = rows[0]["height"], rows[0]["width"]
    ours = info["lgmd_sim"]
    fmt = layout.VIDEO_FORMATS[config.video]
    frames = (f"as {fmt.doc}" + (": the frames come back exact, so frame differences are "
                                 "exact" if fmt.lossless else ""))
    outcome = {o: sum(r["outcome"] == o for r in rows) for o in layout.OUTCOMES}
    lines = [
        f"---\n{configs(episodes['data/sha256'].to_pylist())}---\n",
        "# lgmd-sim jitter dataset",
        "",
        f"{total} episodes, {info['total_frames']} frames of camera streams from the lgmd-sim "
        f"jitter world at {h} x {w} pixels, {info['fps']:g} frames per second, with the "
        "world's exact ground truth on every frame (time, carrier and camera pose, camera "
        "angular and linear velocity, the most threatening obstacle's distance, bearing, "
        "closing speed and time to collision, the collision flag, the SSIM with the "
        "previous frame, the action taken"
        + (f"; the membrane potential and alarm of {', '.join(ours['models'])}"
           if ours["models"] else "") + f"). Frames are stored {frames}.",
        "",
        f"Made by lgmd-sim {ours['version']} with the `{config.controller}` controller, "
        f"episode seeds {config.seed} to {config.seed + config.episodes - 1} in every "
        "scenario and at every jitter level (the same seed gives the same world at each "
        "level):",
        "",
        "```bash",
        config.command(),
        "```",
        "",
        "DIR is this folder. The same command gives the same files, byte for byte, "
        f"whatever the number of workers; it resumes an interrupted run. `{layout.RUNS}` "
        "records each run's wall time and the command as typed (it is not part of the "
        "dataset's identity). Check the dataset with `lgmd-sim dataset verify DIR`.",
        "",
        "## Contents",
        "",
        "| scenario | jitter | episodes | frames | collisions | near misses | clear "
        "| ISI mean | ISI min to max |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for c in _counts(episodes):
        isi = (f"{np.mean(c['isi']):.3f} | {min(c['isi']):.3f} to {max(c['isi']):.3f}"
               if c["isi"] else "- | -")
        lines.append(f"| {c['scenario']} | {c['jitter']:g} | {c['episodes']} | {c['frames']} | "
                     f"{c['collision']} | {c['near_miss']} | {c['clear']} | {isi} |")
    lines += [
        "",
        "## Balance",
        "",
        f"Collisions: {outcome['collision']} of {total} episodes "
        f"({100 * outcome['collision'] / total:.0f}%); near misses: {outcome['near_miss']} "
        f"({100 * outcome['near_miss'] / total:.0f}%); clear: {outcome['clear']} "
        f"({100 * outcome['clear'] / total:.0f}%). A near miss is an episode without a "
        f"collision whose closest approach is under {layout.NEAR_MISS_DISTANCE:g} m (the "
        "`closest_approach` column of the episode table has the distance): the episodes on "
        "which false alarms are counted.",
        "",
        "## ISI distribution",
        "",
        "ISI (Eq. 21 of the feedback-LGMD paper) is the mean SSIM of consecutive frames of an "
        "episode: near 1 for a steady camera, 0.63 to 0.76 in the paper's jitter streams.",
        "",
        "| ISI | episodes | |",
        "|---|---:|---|",
    ]
    isi = np.array([r["isi"] for r in rows if r["isi"] is not None])
    if isi.size:
        bins = np.floor(isi / ISI_BIN + 1e-9).astype(int)
        for b in range(bins.min(), bins.max() + 1):
            n = int((bins == b).sum())
            lines.append(f"| {b * ISI_BIN:.2f} to {(b + 1) * ISI_BIN:.2f} | {n} | "
                         f"{'#' * n} |")
    noise_note = ""
    if ours["noise_variants"]:
        noise_note = (
            f"Noise variants ({', '.join(ours['noise_variants'])}) are views: derived "
            "from the clean frames on loading (`episode.frames(noise=...)`), the same every "
            "time, not stored; the models' responses to them are label columns "
            "(`MODEL.potential[VARIANT]`).")
    lines += [
        "",
        "## Contact sheet",
        "",
        "![contact sheet](meta/contact_sheet.png)",
        "",
        "A row per scenario, a column per jitter level (episode seed "
        f"{config.seed}){', then each noise variant of the last column' if config.noise else ''}"
        "; each tile shows the frame (f) 0.5 s before the collision, or before the closest "
        "approach.",
        "",
        "## Files and loading",
        "",
        "The layout follows the LeRobot dataset v3 conventions (meta/info.json with the "
        "feature schema, an episode table in meta/episodes/, chunked Parquet data with "
        "`episode_index`, `frame_index`, `timestamp`, `index`), one data file and one "
        "video file per episode; lgmd-sim's docs/guides/datasets.md says where the layout "
        f"departs from LeRobot's. `{layout.STATS}` holds per-feature statistics (as LeRobot's). "
        "The labels load without lgmd-sim: `datasets.load_dataset(\"DIR\")` (this card's "
        "`configs` block names the data files, so a Hugging Face Hub upload of the folder "
        "loads the same way; its configuration is named after a digest of the data files, "
        "as `datasets` caches by folder name and configuration), "
        "`pyarrow.parquet.read_table(\"DIR/data\")` or "
        "`pandas.read_parquet(\"DIR/data\")`; the videos open with OpenCV and FFmpeg. "
        "With lgmd-sim: `lgmd_sim.data.open(\"DIR\")` gives episodes with frames and "
        "labels, filters and a clip sampler. " + noise_note,
        "",
        "## Per-frame labels",
        "",
        "Every data file has the same schema, one row per frame (`meta/info.json`'s "
        "`features` holds it in LeRobot's form):",
        "",
        "| column | type | unit | meaning |",
        "|---|---|---|---|",
    ]
    lines += [f"| `{c.name}` | {c.type} | {c.unit or '-'} | {c.doc} |"
              for c in layout.columns(config.models, config.noise)]
    lines.append("")
    return "\n".join(lines)
