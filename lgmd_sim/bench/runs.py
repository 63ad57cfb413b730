"""A benchmark's output folder: its configuration, one record per finished job, resuming.

Layout of ``DIR``:

- ``run.json``: the configuration (what identifies the run), the exact command, the
  package version, the machine, and once complete the wall time;
- ``records/<key>.json``: one record per finished job, each written atomically as the job
  finishes, so that an interrupted run keeps them and ``--resume`` runs only the rest;
- the tables and figures the benchmark makes from the records at the end.

A folder that is not empty is used only to resume the same configuration: anything else
is refused with one line naming the difference.
"""

from __future__ import annotations

import csv
import io
import json
import os
import platform
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from lgmd_sim import __version__
from lgmd_sim.fileio import write_text_atomic

__all__ = ["RunFolder", "csv_text", "machine"]


def machine() -> dict[str, Any]:
    """The machine a run ran on."""
    from lgmd_sim.speed import cpu_name

    return {"cpu": cpu_name(), "cores": os.cpu_count(), "python": platform.python_version(),
            "platform": platform.platform()}


def csv_text(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """Rows as CSV with the given columns; None becomes an empty cell."""
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(columns)
    for r in rows:
        writer.writerow(["" if r.get(c) is None else r[c] for c in columns])
    return out.getvalue()


def _difference(old: Mapping[str, Any], new: Mapping[str, Any]) -> str:
    for key in sorted(set(old) | set(new)):
        if old.get(key) != new.get(key):
            return f"{key}: {old.get(key)!r} there, {new.get(key)!r} now"
    return ""


class RunFolder:
    """The folder of one benchmark run.

    Args:
        path: the folder (made if missing).
        config: JSON-ready configuration; a folder holding another one is refused.
        resume: continue the run already in the folder (same configuration).
        command: the command line that made the run, for the record.
    """

    def __init__(self, path: str | os.PathLike, config: Mapping[str, Any], resume: bool,
                 command: str) -> None:
        self.path = Path(path)
        self.config = json.loads(json.dumps(config))  # as it will read back
        self.records_dir = self.path / "records"
        run_json = self.path / "run.json"
        if self.path.exists() and not self.path.is_dir():
            raise ValueError(f"output folder {self.path} is a file")
        if self.path.is_dir() and any(self.path.iterdir()):
            if not run_json.is_file():
                raise ValueError(f"output folder {self.path} is not empty and holds no run: "
                                 "choose an empty or new folder")
            try:
                old = json.loads(run_json.read_text())["config"]
            except (ValueError, KeyError) as exc:
                raise ValueError(f"{run_json} is unreadable ({exc}): choose another folder "
                                 "or remove it") from None
            if old != self.config:
                raise ValueError(f"output folder {self.path} holds a run with another "
                                 f"configuration ({_difference(old, self.config)}): choose "
                                 "another folder")
            if not resume:
                raise ValueError(f"output folder {self.path} already holds this run: add "
                                 "--resume to complete it, or choose another folder")
            # the earlier sessions of this run: the command that started it stays its command
            record = json.loads(run_json.read_text())
            earlier = record.get("sessions") or [  # a run.json from before sessions
                {k: record[k] for k in ("command", "wall_time_s") if k in record}]
        else:
            earlier = []
        self.started = time.time()
        self._sessions = [*earlier, {"command": command,
                                     "started": time.strftime("%Y-%m-%d %H:%M:%S")}]
        self._meta: dict[str, Any] = {
            "config": self.config,
            "command": self._sessions[0]["command"],
            "version": __version__,
            "machine": machine(),
            "sessions": self._sessions,
        }
        self.records_dir.mkdir(parents=True, exist_ok=True)
        write_text_atomic(run_json, json.dumps({**self._meta, "status": "running"}, indent=2))

    def done(self) -> set[str]:
        """Keys of the jobs whose records are stored."""
        return {p.stem for p in self.records_dir.glob("*.json")}

    def store(self, key: str, record: Mapping[str, Any]) -> None:
        """Store one job's record (atomically: a killed run leaves no half record)."""
        write_text_atomic(self.records_dir / f"{key}.json",
                          json.dumps(record, allow_nan=False, separators=(",", ":")))

    def records(self, keys: Iterable[str] | None = None) -> list[dict[str, Any]]:
        """Stored records, in key order (only `keys`, when given)."""
        wanted = sorted(self.done() if keys is None else keys)
        return [json.loads((self.records_dir / f"{k}.json").read_text()) for k in wanted]

    def finish(self, **facts: Any) -> None:
        """Mark the run complete in run.json, with its wall time (summed over the sessions
        that ran it, each session's own kept) and any other facts."""
        self._sessions[-1]["wall_time_s"] = round(time.time() - self.started, 1)
        total = sum(s.get("wall_time_s", 0.0) for s in self._sessions)
        write_text_atomic(self.path / "run.json", json.dumps(
            {**self._meta, "status": "complete", "wall_time_s": round(total, 1), **facts},
            indent=2))
