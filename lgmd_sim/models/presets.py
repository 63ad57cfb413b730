"""Presets that come from data files rather than code: the calibrated ones.

Two files give them, the second on top of the first:

- the shipped presets, ``lgmd_sim/models/calibrated.json`` (`CALIBRATED`), which change
  only by the release step in a checkout (``scripts/ship_presets.py DIR``);
- the user's presets, ``calibrated.json`` in the user data folder (`user_data_dir`:
  ``$LGMD_SIM_DATA_DIR``, else the platform's, e.g. ``~/.local/share/lgmd-sim``), which
  ``lgmd-sim calibrate --save-presets`` writes (or any file, ``--presets-file``).

Saving merges (`merge_presets`): only the presets of the detectors calibrated change, each
keeping the calibration that made it (command, seeds, resolution, budget). A calibration
never writes into the package.
"""

from __future__ import annotations

import functools
import json
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from lgmd_sim.fileio import read_json, write_text_atomic

__all__ = ["CALIBRATED", "DATA_DIR_VARIABLE", "PACKAGE", "check_presets_file", "data_presets",
           "merge_presets", "preset_files", "user_data_dir", "user_presets_file"]

#: The shipped calibrated presets of every model.
CALIBRATED = Path(__file__).with_name("calibrated.json")
#: The installed package, which no calibration writes into.
PACKAGE = Path(__file__).resolve().parents[1]
#: The environment variable naming the user data folder (its calibrated.json).
DATA_DIR_VARIABLE = "LGMD_SIM_DATA_DIR"
#: What a preset keeps of the calibration that made it.
PROVENANCE = ("command", "objective", "search_seeds", "heldout_seeds", "resolution", "budget",
              "figure")


def user_data_dir() -> Path:
    """The folder of this user's lgmd-sim data: ``$LGMD_SIM_DATA_DIR``, else the
    platform's user data folder (Linux: ``$XDG_DATA_HOME/lgmd-sim``, by default
    ``~/.local/share/lgmd-sim``; macOS: ``~/Library/Application Support/lgmd-sim``;
    Windows: ``%LOCALAPPDATA%\\lgmd-sim``)."""
    named = os.environ.get(DATA_DIR_VARIABLE)
    if named:
        return Path(named).expanduser()
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = str(Path.home() / "Library" / "Application Support")
    else:
        xdg = os.environ.get("XDG_DATA_HOME", "")
        # the XDG specification: a relative path is invalid and is ignored
        base = xdg if os.path.isabs(xdg) else str(Path.home() / ".local" / "share")
    return Path(base) / "lgmd-sim"


def user_presets_file() -> Path:
    """The user's calibrated presets: ``calibrated.json`` in `user_data_dir`."""
    return user_data_dir() / "calibrated.json"


def _files() -> list[Path]:
    """The presets files the models read, later ones on top."""
    return [CALIBRATED, user_presets_file()]


def _read(path: Path) -> dict[str, Any]:
    """One presets file ({} when it does not exist), its shape checked."""
    try:
        stat = path.stat()
    except FileNotFoundError:
        return {}
    except OSError as exc:
        raise OSError(exc.errno, f"cannot read presets file {path}: {exc.strerror}") from exc
    # a file rewritten since (a calibration saved in this process) is read afresh
    return _load(str(path), stat.st_mtime_ns, stat.st_size)


@functools.cache
def _load(path: str, _mtime_ns: int, _size: int) -> dict[str, Any]:
    data = read_json(path)  # one line naming the file where it is unreadable or not JSON
    presets = data.get("presets") if isinstance(data, dict) else None
    if not isinstance(presets, dict) or not all(
            isinstance(v, dict) for v in presets.values()):
        raise ValueError(f"presets file {path}: expected an object with \"presets\": "
                         "{model: {preset: {\"from\": ..., \"params\": {...}}}}")
    for model, entries in presets.items():
        for name, entry in entries.items():
            if not (isinstance(entry, dict) and isinstance(entry.get("from"), str)
                    and isinstance(entry.get("params"), dict)):
                raise ValueError(f"presets file {path}: preset {model}/{name} needs \"from\" "
                                 "(a preset of the model) and \"params\" (an object)")
    return data


def check_presets_file(path: Path) -> None:
    """Raise the one-line error a presets file would give (nothing if it is absent)."""
    _read(path)


def _entries(model: str) -> dict[str, tuple[Mapping[str, Any], Path]]:
    """Each data-file preset of `model`: its entry and the file it comes from."""
    out: dict[str, tuple[Mapping[str, Any], Path]] = {}
    for path in _files():
        for name, entry in _read(path).get("presets", {}).get(model, {}).items():
            out[name] = (entry, path)
    return out


def data_presets(model: str, own: Mapping[str, Mapping[str, Any]]
                 ) -> dict[str, dict[str, Any]]:
    """The data-file presets of `model`, each resolved against the model's own preset it
    starts from (its "from"); the user's on top of the shipped ones."""
    out = {}
    for name, (entry, path) in _entries(model).items():
        if name in own:
            raise ValueError(f"presets file {path}: preset {model}/{name} has the name of one "
                             f"of the model's own presets ({', '.join(own)})")
        if entry["from"] not in own:
            raise ValueError(f"presets file {path}: preset {model}/{name} starts from "
                             f"{entry['from']!r}, not a preset of {model} ({', '.join(own)})")
        out[name] = {**own[entry["from"]], **entry["params"]}
    return out


def preset_files(model: str) -> dict[str, Path]:
    """The file each data-file preset of `model` comes from."""
    return {name: path for name, (_entry, path) in _entries(model).items()}


def merge_presets(target: Path, calibration: Mapping[str, Any]) -> None:
    """Put the presets of `calibration` (a calibration's calibrated.json) into the presets
    file `target` (made if absent): those presets replace theirs, every other stays; each
    keeps the calibration that made it (its "calibration": `PROVENANCE`)."""
    merged: dict[str, dict[str, Any]] = {}
    for data in (_read(Path(target)), calibration):
        # a preset without its own record was made by the file's calibration
        made = {k: data[k] for k in PROVENANCE if k in data}
        for model, entries in data.get("presets", {}).items():
            for name, entry in entries.items():
                merged.setdefault(model, {})[name] = {
                    **({"calibration": made} if made else {}), **entry}
    write_text_atomic(target, json.dumps({"presets": merged}, indent=2) + "\n")
