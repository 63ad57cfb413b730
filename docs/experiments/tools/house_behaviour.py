"""Behaviour before and after a reorganisation: tiny runs of the user's commands, digested.

    python docs/experiments/tools/house_behaviour.py run OUT     # runs the commands into OUT
    python docs/experiments/tools/house_behaviour.py digest OUT  # digests OUT again
    python docs/experiments/tools/house_behaviour.py compare A B  # A, B: two OUT folders

`run` writes OUT/exits.json (each command's exit status) and OUT/digest.json: for every
file the commands wrote, its content with what changes from run to run left out (times,
paths, the machine, the package's version): JSON as values, Markdown as lines with its
tables' timed columns left out, tables, images, videos and arrays as hashes of their
decoded content.
`compare` lists what differs, file by file and key by key; exit status 1 if anything does.
The commands are those a user types (a smoke benchmark row, a dataset, a record and
detect, a short training, a closed-loop bench, the leaderboard of the shipped rows), so a
reorganisation that keeps them equal kept the behaviour the issue asks to keep.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[3]
TRAIN_ENV = "lgmd_sim/StationaryApproach-v0"

#: name -> arguments of `lgmd-sim`, with {out} for the run's folder and {config} for a file
#: holding `TRAIN_KEYS`
COMMANDS: dict[str, list[str]] = {
    "smoke": ["benchmark", "--smoke", "--out", "{out}/smoke", "--no-progress",
              "lgmd1/robot-image@loom-steer"],
    "dataset": ["dataset", "generate", "--out", "{out}/dataset", "--scenarios",
                "StationaryApproach", "--jitter", "0", "--episodes", "2", "--resolution",
                "small", "--set", "time_limit=0.5", "--no-progress", "--workers", "1"],
    "record": ["record", "StationaryApproach", "{out}/clip.mkv", "--seed", "3",
               "--resolution", "small", "--no-progress"],
    "detect": ["detect", "{out}/clip.mkv", "--out", "{out}/detect", "--models", "lgmd1",
               "--no-progress"],
    "train": ["train", "--algo", "ppo", "--env", TRAIN_ENV, "--resolution", "small", "--hp",
              "n_steps=64", "--hp", "batch_size=64", "--config", "{config}", "--steps", "128",
              "--no-progress", "--out", "{out}/train"],
    "bench": ["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter", "0",
              "--controllers", "straight,loom-steer", "--models", "lgmd1", "--seeds", "2",
              "--resolution", "small", "--no-progress", "--out", "{out}/bench"],
    "leaderboard": ["leaderboard", *sorted(str(p.relative_to(ROOT)) for p in
                                           (ROOT / "docs/benchmark/v2/runs").glob("*/result.json")),
                    "--out", "{out}/leaderboard.md"],
}

#: the short training's `lgmd-sim train --config` keys (outside OUT: not a file a command
#: wrote)
TRAIN_KEYS = "eval_every = 128\neval_seeds = 2\ncheckpoint_every = 128\n"

#: keys whose values change from run to run whatever the code does
VOLATILE = re.compile(r"time|seconds|wall|date|when|elapsed|started|finished|host|machine|"
                      r"processor|cpu|platform|python|version|path|dir$|folder|command|^out$|"
                      r"fps|per_s|rate_hz_measured|session|pid|created|git|commit", re.I)


def _strip(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in sorted(value.items()) if not VOLATILE.search(k)}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    if isinstance(value, str) and (str(ROOT) in value or "/tmp" in value):
        return "<path>"
    return value


def _hash(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def _digest(path: Path) -> Any:
    suffix = path.suffix.lower()
    if suffix == ".json":
        return _strip(json.loads(path.read_text()))
    if suffix == ".jsonl":
        return [_strip(json.loads(line)) for line in path.read_text().splitlines() if line]
    if suffix == ".csv":
        rows = list(csv.reader(io.StringIO(path.read_text())))
        # by name: a logger may write its columns in another order from run to run
        keep = sorted((i for i, name in enumerate(rows[0]) if not VOLATILE.search(name)),
                      key=lambda i: rows[0][i]) if rows else []
        return _hash(json.dumps([[r[i] for i in keep if i < len(r)] for r in rows]).encode())
    if suffix in (".png", ".jpg"):
        import cv2
        return _hash(cv2.imread(str(path), cv2.IMREAD_UNCHANGED).tobytes())
    if suffix in (".mkv", ".avi", ".mp4"):
        import cv2
        video, frames = cv2.VideoCapture(str(path)), hashlib.sha256()
        while (frame := video.read())[0]:
            frames.update(frame[1].tobytes())
        return frames.hexdigest()[:16]
    if suffix in (".npz", ".npy"):
        import numpy as np
        arrays = np.load(path)
        items = arrays.items() if suffix == ".npz" else [("", arrays)]
        return {k: _hash(np.ascontiguousarray(v).tobytes()) for k, v in sorted(items)}
    if suffix == ".parquet":
        import pyarrow.parquet as pq
        return _hash(json.dumps(pq.read_table(path).to_pydict(), default=str).encode())
    if suffix == ".md":
        return _markdown(path.read_text())
    return "present"  # checkpoints, logs: their content carries times; their presence counts


#: a Markdown table's columns that are timings (steps/s, their ratios, wall times)
TIMED_COLUMN = re.compile(r"/s\b|ratio|" + VOLATILE.pattern, re.I)


def _markdown(text: str) -> list[str]:
    """A page's lines, its tables without their timed columns."""
    lines, drop = [], set()
    for line in text.splitlines():
        if not line.startswith("|"):
            drop = set()
            lines.append(_strip(line))
            continue
        cells = line.strip("|").split("|")
        if not drop and not set(line) <= set("|-: "):
            drop = {i for i, c in enumerate(cells) if TIMED_COLUMN.search(c)} or {-1}
        lines.append("|".join(c for i, c in enumerate(cells) if i not in drop))
    return lines


def _name(path: Path) -> str:
    """A file's name without what a run stamps into it (TensorBoard's time and host)."""
    return re.sub(r"events\.out\.tfevents\..*", "events.out.tfevents", str(path))


def run(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=False)
    lgmd = [sys.executable, "-m", "lgmd_sim.cli"]
    exits = {}
    with tempfile.TemporaryDirectory() as folder:
        config = Path(folder) / "train.toml"
        config.write_text(TRAIN_KEYS)
        for name, arguments in COMMANDS.items():
            start = time.time()
            done = subprocess.run([*lgmd, *(a.format(out=out, config=config)
                                            for a in arguments)],
                                  cwd=ROOT, capture_output=True, text=True)
            exits[name] = done.returncode
            print(f"{name}: exit {done.returncode} in {time.time() - start:.0f} s", flush=True)
            if done.returncode:
                print(done.stderr[-2000:], file=sys.stderr)
    (out / "exits.json").write_text(json.dumps(exits))
    digest(out)


def digest(out: Path) -> None:
    """OUT/digest.json, from the files the commands wrote."""
    files = sorted(p for p in out.rglob("*") if p.is_file() and p.name != "digest.json")
    found = {_name(p.relative_to(out)): _digest(p) for p in files}
    (out / "digest.json").write_text(json.dumps(found, indent=1, sort_keys=True))


def _differences(a: Any, b: Any, where: str) -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b))
                for d in (_differences(a[k], b[k], f"{where}.{k}") if k in a and k in b
                          else [f"{where}.{k}: only in {'A' if k in a else 'B'}"])]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in _differences(x, y, f"{where}[{i}]")]
    return [] if a == b else [f"{where}: {str(a)[:80]} != {str(b)[:80]}"]


def compare(a: Path, b: Path) -> int:
    one, two = (json.loads((p / "digest.json").read_text()) for p in (a, b))
    differences = _differences(one, two, "")
    print("\n".join(differences[:200]) or "equal: every file, but for times and paths")
    print(f"{len(one)} files compared; {len(differences)} differences")
    return 1 if differences else 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["run"] and len(sys.argv) == 3:
        run(Path(sys.argv[2]).resolve())
    elif sys.argv[1:2] == ["digest"] and len(sys.argv) == 3:
        digest(Path(sys.argv[2]).resolve())
    elif sys.argv[1:2] == ["compare"] and len(sys.argv) == 4:
        sys.exit(compare(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        sys.exit(__doc__)
