"""Presets that come from data files rather than code: the calibrated ones.

Two files give them, the second on top of the first:

- the shipped presets, ``lgmd_sim/models/calibrated.json`` (`CALIBRATED`), which change
  only by the release step in a checkout (``docs/experiments/tools/ship_presets.py DIR``);
- the user's presets, ``calibrated.json`` in the user data folder (`user_data_dir`:
  ``$LGMD_SIM_DATA_DIR``, else the platform's, e.g. ``~/.local/share/lgmd-sim``), which
  ``lgmd-sim calibrate --save-presets`` writes (or any file, ``--save-presets PATH``).

Another presets file may stand in for the user's within a block (`user_presets_from`: a
benchmark's calibrated entry's); the jobs made there carry what it holds to the processes
that run them (`carrying_presets`), which are told it rather than look for it.

Saving merges (`merge_presets`): only the presets of the detectors calibrated change, each
keeping the calibration that made it (command, seeds, resolution, budget). Merges into one
file, from any process, take turns (a lock file beside it, ``.NAME.lock``, which stays). A
calibration never writes into the package.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, TypeVar

from lgmd_sim.core.fileio import held_lock, read_json, write_text_atomic

__all__ = ["CALIBRATED", "DATA_DIR_VARIABLE", "PACKAGE", "carrying_presets", "check_presets_file",
           "check_target", "data_presets", "merge_presets", "preset_files", "user_data_dir",
           "user_presets_file", "user_presets_from"]

T = TypeVar("T")

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


#: A presets file as the models read it: where it is (for messages) and what it holds.
_File = tuple[Path, Mapping[str, Any]]
#: The presets file read in place of the user's in this process (`user_presets_from`).
_instead: _File | None = None


def _files() -> list[_File]:
    """The presets files the models read, later ones on top: the shipped ones, then the
    user's or the file that stands in for them."""
    if _instead is not None:
        return [(CALIBRATED, _read(CALIBRATED)), _instead]
    return [(path, _read(path)) for path in (CALIBRATED, user_presets_file())]


@contextlib.contextmanager
def user_presets_from(file: str | os.PathLike | None) -> Iterator[None]:
    """Within the block, the models of this process read the presets file `file` in place
    of the user's (`user_presets_file`, which is not changed), as it is on entering it;
    None: the user's, or the file that stands in for them already. The jobs made in the
    block take what it holds to their workers (`carrying_presets`)."""
    with _standing_in(None if file is None else (Path(file), _read(Path(file)))):
        yield


def carrying_presets(fn: Callable[..., T]) -> Callable[..., T]:
    """`fn` as the function of a job (`lgmd_sim.core.jobs.Job`) that builds its detectors
    from the presets this process reads now: where a file stands in for the user's
    (`user_presets_from`), the job carries what it holds to the process that runs it (a
    pool's worker, a Ray task, on any machine); `fn` itself where none does."""
    return fn if _instead is None else functools.partial(_reading, _instead, fn)


def _reading(file: _File, fn: Callable[..., T], /, **kwargs: Any) -> T:
    """``fn(**kwargs)`` with `file` in place of the user's presets (a job's call)."""
    with _standing_in(file):
        return fn(**kwargs)


@contextlib.contextmanager
def _standing_in(file: _File | None) -> Iterator[None]:
    """Within the block, `file` stands in for the user's presets file (None: as before)."""
    global _instead
    before = _instead
    _instead = before if file is None else file
    try:
        yield
    finally:
        _instead = before


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
    return _parse(path)


def _parse(path: str | Path) -> dict[str, Any]:
    """One presets file as it is now, its shape checked."""
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


def check_target(path: Path) -> None:
    """Raise the one-line error merging into the presets file `path` would give, before
    the work whose presets it is to take: a file that is no presets file or cannot be
    written, a folder that cannot be written or made. Nothing is made.

    Raises:
        ValueError: naming `path` and what stands in the way.
    """
    check_presets_file(path)
    folder = path.parent
    present = next(p for p in (folder, *folder.parents) if p.exists())
    if not present.is_dir():
        raise ValueError(f"presets file {path}: its folder {folder} cannot be made: {present} "
                         "is not a folder")
    exists = path.exists()
    try:
        if exists:
            os.close(os.open(path, os.O_WRONLY | os.O_APPEND))  # opened, not changed
        else:
            # a file made and gone, as the merge's temporary will be (not os.access: a
            # read-only file system or a root user defeat it)
            tempfile.TemporaryFile(dir=present).close()
    except OSError as exc:
        what = ("it cannot be written" if exists else
                f"its folder {folder} cannot be written" if present == folder else
                f"its folder {folder} cannot be made in {present}")
        raise ValueError(f"presets file {path}: {what}: {_reason(exc)}") from None


def _reason(exc: OSError) -> str:
    """An OSError's reason alone, without the file it names."""
    return os.strerror(exc.errno) if exc.errno else str(exc)


def _entries(model: str) -> dict[str, tuple[Mapping[str, Any], Path]]:
    """Each data-file preset of `model`: its entry and the file it comes from."""
    out: dict[str, tuple[Mapping[str, Any], Path]] = {}
    for path, data in _files():
        for name, entry in data.get("presets", {}).get(model, {}).items():
            out[name] = (entry, path)
    return out


def data_presets(model: str, own: Mapping[str, Mapping[str, Any]]
                 ) -> dict[str, dict[str, Any]]:
    """The data-file presets of `model`, each resolved against the model's own preset it
    starts from (its "from"); the user's on top of the shipped ones.

    Raises:
        ValueError: a preset with the name of one of `own`, starting from none of them, or
            setting a parameter the model does not have (or, in the user's file, to a value
            its check refuses), naming the file, the preset and the parameter.
    """
    entries = _entries(model)
    if not entries:  # a model without data-file presets: its class is not looked into
        return {}
    # Checked here, not where the file is read: a file may hold presets of a plug-in that
    # is not installed now, which are the user's business until that model is used.
    from lgmd_sim.models import model_class  # that package imports this module

    checks = {f.name: f.metadata.get("check")
              for f in dataclasses.fields(model_class(model).Params)}
    out = {}
    for name, (entry, path) in entries.items():
        where = f"presets file {path}: preset {model}/{name}"
        if name in own:
            raise ValueError(f"{where} has the name of one of the model's own presets "
                             f"({', '.join(own)})")
        if entry["from"] not in own:
            raise ValueError(f"{where} starts from {entry['from']!r}, not a preset of {model} "
                             f"({', '.join(own)})")
        unknown = sorted(entry["params"].keys() - checks.keys())
        if unknown:
            raise ValueError(f"{where}: unknown parameter(s) {', '.join(map(repr, unknown))}; "
                             f"valid: {', '.join(sorted(checks))}")
        # the shipped presets are the package's own (its tests make each one); checking
        # their values at every look-up would cost several times the look-up
        if path != CALIBRATED:
            for key, value in entry["params"].items():
                error = checks[key](value) if checks[key] else None
                if error:
                    raise ValueError(f"{where}: parameter {key}={value!r} {error}")
        out[name] = {**own[entry["from"]], **entry["params"]}
    return out


def preset_files(model: str) -> dict[str, Path]:
    """The file each data-file preset of `model` comes from."""
    return {name: path for name, (_entry, path) in _entries(model).items()}


def merge_presets(target: Path, calibration: Mapping[str, Any]) -> None:
    """Put the presets of `calibration` (a calibration's calibrated.json) into the presets
    file `target` (made if absent): those presets replace theirs, every other stays; each
    keeps the calibration that made it (its "calibration": `PROVENANCE`). Merges into one
    file take turns, each reading what the one before wrote.

    Raises:
        ValueError: `target` is no presets file.
        OSError: it cannot be written, naming it (not its lock or temporary).
    """
    target = Path(target)
    try:
        with held_lock(target.with_name(f".{target.name}.lock")):
            # read afresh, not from the cache: another process may have merged since, and
            # within a clock tick a file of the same size would look unchanged
            current = _parse(target) if target.exists() else {}
            merged: dict[str, dict[str, Any]] = {}
            for data in (current, calibration):
                # a preset without its own record was made by the file's calibration
                made = {k: data[k] for k in PROVENANCE if k in data}
                for model, entries in data.get("presets", {}).items():
                    for name, entry in entries.items():
                        merged.setdefault(model, {})[name] = {
                            **({"calibration": made} if made else {}), **entry}
            write_text_atomic(target, json.dumps({"presets": merged}, indent=2) + "\n")
    except OSError as exc:  # the file the user named, not its lock or temporary
        raise OSError(exc.errno, f"cannot write presets file {target}: {_reason(exc)}") from exc
