"""A labelled dataset, made and read three ways: with lgmd-sim's loader, with Hugging Face
`datasets`, and as a LeRobot dataset (docs/guides/datasets.md describes the format).

It generates a tiny dataset with the Python API (the same as `lgmd-sim dataset generate`),
loops over its episodes, loads the per-frame labels as one `datasets` table, exports it
in LeRobot's format and reads the export back, then writes what it counted to
OUT/summary.json. Needs the `data` and `lerobot` extras and `datasets`
(`pip install -e ".[data,lerobot]" datasets`); LeRobot itself is used when installed.

    python examples/dataset_loop.py --out runs/dataset-example

Running it again on the same OUT keeps the episodes already made (a dataset resumes).
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np

from lgmd_sim import data
from lgmd_sim.cli.args import error_line
from lgmd_sim.controllers import options
from lgmd_sim.core.extras import MissingExtra
from lgmd_sim.core.fileio import write_text_atomic
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.core.params import checked, count
from lgmd_sim.data.export import ExportConfig, export
from lgmd_sim.data.generate import GenerateConfig, generate
from lgmd_sim.detect.outputs import check_out_folder

#: The LGMD whose responses join the labels. With the defaults below, LGMD2 (published
#: parameters) alarms shortly before the collision at jitter 0, and at jitter 1 within the
#: first frames, set off by the camera's shake: what the testbed is for.
MODEL = "lgmd2"


def make(out: Path, scenarios: list[str], jitter: list[float], episodes: int,
         workers: int) -> Path:
    """Generate the dataset into OUT/dataset: every scenario at every jitter level, an
    LGMD's potential and alarm among the labels."""
    config = GenerateConfig(
        scenarios=tuple(scenarios), jitter=tuple(jitter), episodes=episodes,
        resolution=(64, 96),  # small frames: seconds, not minutes (even sizes, for H.264)
        models=(MODEL,))  # its potential and alarm on every frame, as label columns
    summary = generate(config, out / "dataset", RunOptions(workers=workers, progress=False))
    print(f"{summary.episodes} episodes, {summary.frames} frames in {out / 'dataset'}")
    return out / "dataset"


def loop_with_lgmd_sim(folder: Path) -> dict[str, int]:
    """Each episode with its frames (decoded on demand, exact) and labels: when the LGMD
    first alarmed, against the collision frame of the ground truth."""
    ds = data.open(folder)
    frames = 0
    for ep in ds:
        video = ep.frames()  # (T, H, W, 3) uint8, the pixels as rendered
        alarms = np.flatnonzero(ep.labels[f"{MODEL}.alarm"].to_numpy())
        first = int(alarms[0]) if len(alarms) else None
        print(f"  {ep.scenario} jitter {ep.jitter:g} seed {ep.seed}: {ep.outcome}, "
              f"{len(video)} frames, first alarm at frame {first}, collision at "
              f"{ep.collision_frame}")
        frames += len(video)
    # the clip sampler: every 8-frame window of every episode once, in a shuffled order
    windows = sum(1 for _ in ds.clips(8, stride=4, seed=0))
    return {"episodes": len(ds), "frames": frames, "windows": windows}


def loop_with_hf_datasets(folder: Path, cache: Path) -> dict[str, int]:
    """The labels as one Hugging Face table: the dataset's card names its Parquet files,
    so `load_dataset(FOLDER)` finds them (as it would on the Hub)."""
    from datasets import load_dataset

    # cache_dir keeps the Arrow cache inside OUT; without it datasets uses ~/.cache
    table = load_dataset(str(folder), split="train", cache_dir=str(cache))
    near = table.filter(lambda ttc: ttc < 1.0, input_columns="threat_ttc")
    per_episode = np.bincount(table["episode_index"])
    print(f"  datasets: {len(table)} frames, {len(near)} of them under 1 s from contact; "
          f"frames per episode {per_episode.tolist()}")
    return {"rows": len(table), "under_1s": len(near), "episodes": len(per_episode)}


def loop_as_lerobot(folder: Path, dest: Path, cache: Path) -> dict[str, int]:
    """Export to LeRobot's format (v3.0, frames re-encoded as H.264 MP4) and read it back:
    with LeRobot when it is installed, else as LeRobot reads it."""
    if dest.exists():
        shutil.rmtree(dest)  # an export goes into a new folder: remake it on a rerun
    export(ExportConfig(folder, dest))
    try:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset
    except ImportError:  # not an extra: it does not install beside lgmd-sim's pins
        return read_like_lerobot(dest, cache)
    ds = LeRobotDataset(f"local/{dest.name}", root=dest)
    first = ds[0]["observation.images.camera"]  # (3, H, W) float in [0, 1]
    print(f"  LeRobotDataset: {len(ds)} frames, the first {tuple(first.shape)}")
    return {"frames": len(ds), "decoded": len(ds)}


def read_like_lerobot(dest: Path, cache: Path) -> dict[str, int]:
    """An export read without LeRobot, as LeRobot reads it: the labels with `datasets`,
    episode 0's frames with PyAV from the file meta/info.json's template names."""
    import av
    from datasets import load_dataset

    labels = load_dataset(str(dest), split="train", cache_dir=str(cache))
    info = json.loads((dest / "meta" / "info.json").read_text())
    video = dest / info["video_path"].format(video_key="observation.images.camera",
                                             chunk_index=0, file_index=0)
    with av.open(str(video)) as container:
        decoded = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    print(f"  LeRobot export: {len(labels)} frames of labels; episode 0's video "
          f"{len(decoded)} frames of {decoded[0].shape} (read with datasets and PyAV: "
          "LeRobot is not installed)")
    return {"frames": len(labels), "decoded": len(decoded)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("dataset-example"),
                        help="output folder (default ./dataset-example)")
    parser.add_argument("--scenarios", default="StationaryApproach,PassBy",
                        help="comma-separated scenario names (lgmd-sim envs)")
    parser.add_argument("--jitter", default="0,1",
                        help="comma-separated jitter levels")
    parser.add_argument("--episodes", type=int, default=1,
                        help="episodes per scenario and jitter level (default 1)")
    parser.add_argument("--workers", type=int, default=1,
                        help="local worker processes (default 1)")
    args = parser.parse_args()
    try:  # OUT is made by the dataset's generation, once every option has been checked
        check_out_folder(args.out)
        checked("workers", args.workers, count)
        folder = make(args.out, args.scenarios.split(","),
                      list(options.jitter_levels(args.jitter)), args.episodes, args.workers)
    except (ValueError, OSError, MissingExtra) as exc:  # as lgmd-sim: one line, status 2
        parser.exit(2, f"{parser.prog}: error: {error_line(exc, parser, args)}\n")
    cache = args.out / "hf-cache"
    summary = {"lgmd_sim": loop_with_lgmd_sim(folder),
               "datasets": loop_with_hf_datasets(folder, cache),
               "lerobot": loop_as_lerobot(folder, args.out / "lerobot", cache)}
    write_text_atomic(args.out / "summary.json", json.dumps(summary, indent=2) + "\n")
    print(f"wrote {args.out / 'summary.json'}")


if __name__ == "__main__":
    main()
