"""A detection's files: per clip a CSV (every frame), a JSON summary and a figure, written
as a set; their names; and the output folder's check before any frame is read."""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from lgmd_sim.core.fileio import write_files
from lgmd_sim.detect.results import Detection

__all__ = ["check_out_folder", "output_names", "write_outputs"]


def _write_csv(path: Path, d: Detection) -> None:
    names = list(d.models)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["frame", "time_s", "ssim"]
                   + [c for n in names for c in (f"{n}_potential", f"{n}_alarm")])
        for t in range(d.frames):
            row: list[Any] = [t, f"{t / d.fps:.6f}", "" if t == 0 else f"{d.ssim[t]:.6f}"]
            for n in names:
                tr = d.models[n]
                row += [f"{tr.potential[t]:.6f}", int(tr.alarm[t])]
            w.writerow(row)


def _write_figure(path: Path, d: Detection) -> None:
    """One panel per model: its potentials with their thresholds, each first alarm and the
    collision marked; the SSIM of consecutive frames below (`detection_figure`). The PNG
    records the detection's configuration (`lgmd_sim.core.pngtext`)."""
    from lgmd_sim.core.pngtext import png_text
    from lgmd_sim.detect.figure import detection_figure

    fig = detection_figure(d)
    config = {"video": Path(d.video).name, "models": list(d.models),
              "collision_frame": d.collision_frame, "noise": d.noise,
              "noise_seed": d.noise_seed}
    fig.savefig(path, format="png", dpi=120, metadata=png_text(None, config))


def write_outputs(d: Detection, out_dir: str | os.PathLike, stem: str) -> dict[str, Path]:
    """Write <stem>.csv, <stem>.json and <stem>.png into out_dir: the set as a whole, or
    (on any error) none of it, the previous set left as it was."""
    out_dir = Path(out_dir)
    paths = {ext: out_dir / f"{stem}.{ext}" for ext in ("csv", "json", "png")}
    write_files({
        paths["csv"]: lambda tmp: _write_csv(tmp, d),
        paths["json"]: lambda tmp: tmp.write_text(
            json.dumps(d.summary(), indent=2, allow_nan=False) + "\n"),
        paths["png"]: lambda tmp: _write_figure(tmp, d),
    })
    return paths


def output_names(videos: Sequence[str]) -> list[str]:
    """Unique, predictable output names: each video's stem; where stems are shared, the
    file name (``clip.avi``, ``clip.mp4``); where those are shared too, the parent folder
    joined on (``day1_clip.mp4``); and where a name is still taken, ``~2``, ``~3``..."""
    paths = [Path(os.path.normpath(v)) for v in videos]
    levels = [
        [p.stem or "video" for p in paths],
        [p.name or "video" for p in paths],
        ["_".join(p.parts[-2:]) or "video" for p in paths],
    ]
    names: list[str] = []
    taken: set[str] = set()  # case-folded: some file systems ignore case
    for i in range(len(paths)):
        name = next((lv[i] for lv in levels
                     if [x.casefold() for x in lv].count(lv[i].casefold()) == 1), levels[-1][i])
        base, k = name, 1
        while name.casefold() in taken:
            k += 1
            name = f"{base}~{k}"
        taken.add(name.casefold())
        names.append(name)
    return names


def check_out_folder(out: Path) -> None:
    """Fail before any frame is processed if the output folder could not be written
    (it is made only when the first result is written)."""
    existing = out.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        what = "is a file" if existing == out.absolute() else f"is inside the file {existing}"
        raise ValueError(f"output folder {out} {what}, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write output folder {out}: permission denied on {existing}")
