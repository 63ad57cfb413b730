"""A run's folder: its configuration, every session that ran it, one record per finished
job, resuming.

Every resumable job keeps its results this way (the benchmarks, the calibration,
training, dataset generation). Layout of ``DIR``:

- ``run.json`` (or the job's own `record` path): its `SCHEMA`, the configuration (what
  identifies the run), the package version, the machine of the latest session, the
  command that started the run, and every session (the first run and each resume: its
  command, start, wall time and machine, and the facts the job adds); ``status`` is
  "running" until the job calls `RunFolder.finish`;
- ``records/<key>.json``: one record per finished job, written atomically as it
  finishes, so that an interrupted run keeps them and resuming runs only the rest; a
  record read back must be a JSON object holding the fields its job declares
  (`RunFolder.records`), else it is refused naming the file;
- whatever the job writes beside them.

A folder that is not empty is used only to continue the same configuration: another
configuration, a folder that holds no run, a run recorded by another schema (an older
lgmd-sim's, which is not converted: run it again) or (without ``resume``) a run already
there is refused with one line naming the difference or the way to resume.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeAlias

from lgmd_sim import __version__
from lgmd_sim.core.fileio import canonical_json, read_json, write_text_atomic
from lgmd_sim.core.machine import machine

__all__ = ["NULL", "NUMBER", "RECORD", "Fields", "Maybe", "RunFolder", "RunResult", "difference",
           "read_record"]

#: The run's record, relative to its folder.
RECORD = "run.json"
#: The layout of a run's record and of its configuration. 2: since lgmd-sim's house
#: reorganisation (every configuration key recorded, whatever its value); a record without
#: it is older. A run of another schema is refused, never converted.
SCHEMA = 2
#: What the record says of every run; a job's own facts come beside them.
_OWN_KEYS = ("schema", "config", "command", "version", "machine", "sessions", "status",
             "wall_time_s")

#: What a record (or a field of one) must hold: a type (isinstance); a mapping of field
#: names to what each holds (a JSON object with those fields); a one-item list (a JSON
#: array whose every item holds that item); a tuple of these (any one of them); `Maybe`.
Fields: TypeAlias = "type | Mapping[str, Fields] | list[Fields] | tuple[Fields, ...] | Maybe"
#: A field that holds a number (JSON has one kind: int or float here).
NUMBER = (int, float)
#: A field that may be null.
NULL = type(None)


@dataclass(frozen=True)
class Maybe:
    """A field a record may lack (its job reads it with a default); where it is there, it
    holds `fields`."""

    fields: Fields


def difference(there: Any, here: Any, path: str = "") -> tuple[str, Any, Any] | None:
    """The first (dotted key, value there, value here) where two configurations differ."""
    if isinstance(there, dict) and isinstance(here, dict):
        for k in sorted(set(there) | set(here)):
            found = difference(there.get(k), here.get(k), f"{path}.{k}" if path else k)
            if found:
                return found
        return None
    return None if there == here else (path, there, here)


def _mismatch(value: Any, fields: Fields, where: str = "") -> str | None:
    """What of `value` does not hold what `fields` describes, or None."""
    if isinstance(fields, Mapping):
        if not isinstance(value, dict):
            return f"{where or 'it'} is not a JSON object"
        for name, holds in fields.items():
            at = f"{where}.{name}" if where else name
            if name in value:
                found = _mismatch(value[name], holds, at)
                if found:
                    return found
            elif not isinstance(holds, Maybe):
                return f"it has no {at!r}"
        return None
    if isinstance(fields, Maybe):
        return _mismatch(value, fields.fields, where)
    if isinstance(fields, list):
        if not isinstance(value, list):
            return f"{where or 'it'} is not a list"
        return next(filter(None, (_mismatch(v, fields[0], f"{where}[{i}]")
                                  for i, v in enumerate(value))), None)
    if isinstance(fields, tuple):
        fits = any(_mismatch(value, f, where) is None for f in fields)
    else:  # JSON's true and false are not numbers, though Python's bool is an int
        fits = isinstance(value, fields) and (fields is bool or not isinstance(value, bool))
    return None if fits else f"{where or 'it'} is {json.dumps(value)[:40]}"


def read_record(file: Path, fields: Fields, remedy: str) -> Any:
    """The JSON in `file`, which must hold `fields`; ValueError naming the file and
    `remedy` where it cannot be read or holds something else."""
    try:
        data = read_json(file)
    except ValueError as exc:
        raise ValueError(f"{exc}: {remedy}") from None
    return _holding(data, file, fields, remedy)


def _holding(data: Any, file: Path, fields: Fields, remedy: str) -> Any:
    """`data`, read from `file`, if it holds `fields` (see `read_record`)."""
    problem = _mismatch(data, fields)
    if problem:
        raise ValueError(f"{file} is not what this run wrote there ({problem}): {remedy}")
    return data


def _show(value: Any) -> str:
    if isinstance(value, list) and all(not isinstance(v, list | dict) for v in value):
        return ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value) or "none"
    return json.dumps(value)


class RunFolder:
    """The folder of one run (see the module's docstring for the layout).

    Args:
        path: the folder (made if missing).
        config: the JSON-ready configuration; a folder holding another one is refused.
        command: the command line of this session, for the record.
        resume: continue the run already in the folder (same configuration); a new or
            empty folder starts a new run either way.
        what: what the run is, for messages ("run", "training run", "dataset").
        resume_hint: how a user continues a run that is there, for the refusal without
            ``resume``.
        record: where the run's record goes, relative to the folder.
        identity: a file, relative to the folder, that holds the configuration alone as
            `canonical_json`, written once (a dataset's ``meta/config.json``, part of
            what it ships); None: run.json's "config" identifies the run.
        changeable: configuration keys a resumed session may change (e.g. a training
            run's step budget); the record keeps the latest value.
        start: write the record now (see `start`); the folder is checked either way.
    """

    def __init__(self, path: str | os.PathLike, config: Mapping[str, Any], command: str,
                 *, resume: bool = False, what: str = "run",
                 resume_hint: str = "add --resume to complete it", record: str = RECORD,
                 identity: str | None = None, changeable: Collection[str] = (),
                 start: bool = True) -> None:
        self.path = Path(path)
        self.config = json.loads(json.dumps(config))  # as it will read back
        self.records_dir = self.path / "records"
        self._record_name = record
        self._identity = self.path / identity if identity else None
        if self.path.exists() and not self.path.is_dir():
            raise ValueError(f"output folder {self.path} is a file, not a folder")
        earlier, self._facts = self._earlier(what, resume, resume_hint, changeable)
        self.started = time.time()
        self.session: dict[str, Any] = {"command": command,
                                        "started": time.strftime("%Y-%m-%d %H:%M:%S"),
                                        "machine": machine()}
        self._sessions = [*earlier, self.session]
        if start:
            self.start()

    def start(self) -> None:
        """Write the identity file (once) and the record, status "running": from now on
        the folder holds this run. A job whose last checks need work of its own (a
        training run's first environment steps) checks the folder with ``start=False``,
        then starts it, so that a bad input leaves no folder behind."""
        if self._identity is not None and not self._identity.is_file():
            write_text_atomic(self._identity, canonical_json(self.config))
        self._write("running")

    @staticmethod
    def recorded(path: str | os.PathLike, record: str = RECORD) -> dict[str, Any] | None:
        """The record of the run in `path` (its configuration under "config"), or None
        where there is none; ValueError where it cannot be read."""
        file = Path(path) / record
        if not file.is_file():
            return None
        remedy = "choose another folder or remove it"
        # read once: the schema first, since an older record may lack what this one holds
        data = read_record(file, dict, remedy)
        schema = data.get("schema")
        if schema != SCHEMA:
            raise ValueError(f"{file} was written by another lgmd-sim (record schema "
                             f"{schema or 1}, this one's {SCHEMA}): run it again into a new "
                             "folder")
        return _holding(data, file, {"config": dict, "sessions": [dict]}, remedy)

    def _earlier(self, what: str, resume: bool, resume_hint: str, changeable: Collection[str]
                 ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
        """The earlier sessions of the run in the folder and the facts recorded of it,
        after checking it is this run."""
        if not (self.path.is_dir() and any(self.path.iterdir())):
            return [], {}
        recorded = self.recorded(self.path, self._record_name)
        if self._identity is not None and self._identity.is_file():
            held = read_record(self._identity, {}, "use another folder")
        elif recorded is not None and self._identity is None:
            held = recorded["config"]
        else:
            raise ValueError(f"output folder {self.path} is not empty and holds no {what}: "
                             "choose a new or empty folder")
        diff = difference({k: v for k, v in held.items() if k not in changeable},
                          {k: v for k, v in self.config.items() if k not in changeable})
        if diff:
            key, there, here = diff
            raise ValueError(f"output folder {self.path} holds a {what} made with another "
                             f"configuration: {key} is {_show(there)} there, {_show(here)} "
                             "here; choose another folder")
        if not resume:
            raise ValueError(f"output folder {self.path} already holds this {what}: "
                             f"{resume_hint}, or choose another folder")
        recorded = recorded or {"sessions": []}
        return (list(recorded["sessions"]),
                {k: v for k, v in recorded.items() if k not in _OWN_KEYS})

    @property
    def sessions(self) -> list[dict[str, Any]]:
        """Every session of the run, this one last."""
        return self._sessions

    def done(self) -> set[str]:
        """Keys of the jobs whose records are stored."""
        return {p.stem for p in self.records_dir.glob("*.json")}

    def store(self, key: str, record: Mapping[str, Any]) -> None:
        """Store one job's record (atomically: a killed run leaves no half record)."""
        self.records_dir.mkdir(parents=True, exist_ok=True)
        write_text_atomic(self.records_dir / f"{key}.json",
                          json.dumps(record, allow_nan=False, separators=(",", ":")))

    def records(self, keys: Iterable[str] | None = None,
                fields: Mapping[str, Fields] | None = None) -> list[dict[str, Any]]:
        """Stored records, in key order (only `keys`, when given), each a JSON object
        holding `fields` (what the job reads of it); ValueError naming the first record
        that is not (truncated, or changed since its job wrote it)."""
        wanted = sorted(self.done() if keys is None else keys)
        return [read_record(self.records_dir / f"{k}.json", fields or {},
                            "remove it, and resume to run its job again") for k in wanted]

    def note(self, **facts: Any) -> None:
        """Add facts to the run's record now (e.g. a training run's hyperparameters)."""
        self._facts.update(facts)
        self._write("running")

    def finish(self, **facts: Any) -> None:
        """Mark the run complete, with this session's wall time (the run's is the sum over
        its sessions, each session's own kept) and any other facts of the run."""
        self.session["wall_time_s"] = round(time.time() - self.started, 1)
        self._facts.update(facts)
        self._write("complete")

    def _write(self, status: str) -> None:
        total = sum(s.get("wall_time_s", 0.0) for s in self._sessions)
        record = {"schema": SCHEMA, "config": self.config,
                  "command": self._sessions[0]["command"],
                  "version": __version__, "machine": self.session["machine"],
                  "sessions": self._sessions,
                  "status": status, **({"wall_time_s": round(total, 1)}
                                       if status == "complete" else {}), **self._facts}
        write_text_atomic(self.path / self._record_name, json.dumps(record, indent=2, default=str))


@dataclass(frozen=True)
class RunResult:
    """What a job made: its folder, its summary rows (one per row of summary.csv) and the
    files it wrote into the folder."""

    path: Path
    rows: list[dict[str, Any]]
    files: list[str]
