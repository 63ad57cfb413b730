"""Checking a published row: replay a sample of its episodes on this machine and compare
each with its record, fingerprint and fields (`lgmd_sim.benchmark.fingerprint`), so that a
reader can tell whether a row replays here, and where it parts if not.

`verify` reads an entry's folder as `lgmd-sim benchmark` leaves it (``result.json`` beside
``goal/`` and ``arena/``, each a closed-loop run folder of one record per episode), or as
a row is published: ``episodes.json`` holds the same records, the drawings left out; it
also checks that the result's per-seed parts are what the records give. A calibrated
entry's episodes replay at the preset its folder's presets file holds (`PRESETS`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.benchmark.entries import Entry, parse
from lgmd_sim.benchmark.episode import RECORD_FIELDS, episode
from lgmd_sim.benchmark.fingerprint import first_difference
from lgmd_sim.benchmark.protocol import Protocol
from lgmd_sim.benchmark.run import EPISODES, PRESETS, track_config
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.core.params import checked, count

__all__ = ["Replayed", "verify"]

#: The fields a replay leaves out of the comparison: the top view is drawn for the first
#: seeds only, where the bench asks for it (and a published row leaves it out).
_NOT_COMPARED = ("top_view",)


@dataclass(frozen=True)
class Replayed:
    """One episode replayed: its track and record key, and None where it gave the same bits
    and fields as recorded, else what differed first."""

    track: str
    key: str
    difference: str | None


def _compare(recorded: Mapping[str, Any], replayed: Mapping[str, Any]) -> str | None:
    """What first differs between an episode's record and its replay, in words."""
    if "fingerprint" not in recorded:
        return "its record has no fingerprint (recorded before fingerprints were)"
    step = first_difference(recorded["fingerprint"], replayed["fingerprint"])
    if step is not None:
        shown = {k: replayed[k] for k in ("frames", "collided", "goal_reached")}
        was = {k: recorded.get(k) for k in shown}
        return (f"diverged at step {step} or in the {recorded['fingerprint']['every']} after "
                f"it (recorded {was}, replayed {shown})")
    for key in sorted(set(recorded) | set(replayed)):
        if key in _NOT_COMPARED or key == "fingerprint":
            continue
        if recorded.get(key) != replayed.get(key):
            return (f"the same trajectory, but its record's {key} is {recorded.get(key)!r}, "
                    f"the replay's {replayed.get(key)!r}: the record was changed")
    return None


def _sample(keys: Sequence[str], n: int | None, seed: int) -> list[str]:
    """`n` of `keys` (all: None), drawn by `seed`, in the keys' order."""
    if n is None or n >= len(keys):
        return list(keys)
    picked = np.random.default_rng(seed).choice(len(keys), n, replace=False)
    return [keys[i] for i in sorted(picked)]


def verify(result: str | Path, protocol: Protocol, episodes: int | None = None, *,
           seed: int = 0, options: RunOptions = RunOptions(),
           on_episode: Callable[[Replayed], None] | None = None) -> list[Replayed]:
    """Replay `episodes` of each closed-loop track of the entry whose ``result.json`` (or
    folder) is `result`, of `protocol` (None: every episode; a sample drawn by `seed`
    otherwise), and compare each with its record; `on_episode` is told of each as it is
    checked.

    Raises:
        ValueError: no result of `protocol` there, a track's run folder missing or
            unreadable, or the result's parts not what its records give (one line naming
            it).
    """
    from lgmd_sim.benchmark import scores
    from lgmd_sim.benchmark.leaderboard import load_result, parts
    from lgmd_sim.models.presets import user_presets_from

    path = Path(result)
    file = path / "result.json" if path.is_dir() else path
    claimed = load_result(file, protocol)
    if episodes is not None:
        checked("episodes", episodes, count)
    presets = file.parent / PRESETS  # a calibrated entry's
    out: list[Replayed] = []
    with user_presets_from(presets if presets.is_file() else None):
        for track, part in parts(claimed).items():
            if track in scores.CLOSED_LOOP:
                out += _track(file, track, part, protocol, (episodes, seed),
                              options, on_episode, claimed)
    return out


def _entry(entry: Mapping[str, Any]) -> Entry:
    """A result's entry: a policy's again from its spec (the folder where this checkout
    has it), the others from their recorded fields (a calibrated preset's name too)."""
    if entry["kind"] == "policy":
        return parse(entry["spec"])
    return Entry(entry["spec"], entry["kind"], entry["controller"], entry.get("model"),
                 entry.get("preset"), entry.get("side") or "halves")


def _track(file: Path, track: str, part: Any, protocol: Protocol,
           sample: tuple[int | None, int], options: RunOptions,
           on_episode: Callable[[Replayed], None] | None, claimed: Mapping[str, Any]
           ) -> list[Replayed]:
    """`verify` of one closed-loop track: its run folder beside `file` (a published row's:
    the protocol's for the result's entry, its records from ``episodes.json``), the
    episodes `sample` (how many, the draw's seed) of it."""
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
    from lgmd_sim.core.jobs import Job
    from lgmd_sim.core.parallel import run_jobs
    from lgmd_sim.core.runs import RunFolder, read_record
    from lgmd_sim.models.presets import carrying_presets

    run = file.parent / track
    if (run / "run.json").is_file():
        recorded = read_record(run / "run.json", {"config": dict},
                               f"the folder of {file} holds no {track} run")
        try:
            config = ClosedLoopConfig.from_json(recorded["config"])
        except (KeyError, TypeError) as exc:  # a hand-edited run.json
            raise ValueError(f"{run / 'run.json'}: not a closed-loop run's configuration "
                             f"({type(exc).__name__}: {exc})") from None
    else:  # a published row: its run is the protocol's, for its entry
        config = track_config(_entry(claimed["entry"]), protocol, getattr(protocol, track))
    cells = {c.key(s): (c, s) for c in config.cells() for s in config.seed_list}
    keys = list(cells)
    if (run / "records").is_dir():
        listed = RunFolder(run, config.as_json(), "", resume=True, start=False).records(
            keys, RECORD_FIELDS)
    else:
        listed = _published(file.parent / EPISODES, track, len(keys))
    records = dict(zip(keys, listed, strict=True))
    _check_parts(file, track, part, list(records.values()), protocol)
    played = {"resolution": config.resolution, "cruise": config.cruise,
              "horizon": config.horizon, "top_view": False}
    out: list[Replayed] = []

    def store(job: Job, replayed: dict[str, Any]) -> None:
        checked = Replayed(track, job.key, _compare(records[job.key], replayed))
        out.append(checked)
        if on_episode is not None:
            on_episode(checked)

    play = carrying_presets(episode)  # a calibrated entry's presets, to the workers
    jobs = [Job(k, play, {"cell": cells[k][0], "seed": cells[k][1], **played})
            for k in _sample(keys, *sample)]
    run_jobs(jobs, store, options, desc=f"verify {track}", unit="episode")
    return out


def _published(file: Path, track: str, count: int) -> list[dict[str, Any]]:
    """A published row's records of `track` (its ``episodes.json``), each checked."""
    from lgmd_sim.core.runs import read_record

    remedy = ("a row is replayed against the records/ of its run folders or the "
              f"{EPISODES} that lgmd-sim benchmark writes beside its result")
    published = read_record(file, {track: [RECORD_FIELDS]}, remedy) if file.is_file() else None
    if published is None:
        raise ValueError(f"{file.parent / track}: no records/ of its episodes, nor {file}: "
                         f"{remedy}")
    if len(published[track]) != count:
        raise ValueError(f"{file}: {len(published[track])} {track} episodes, its run holds "
                         f"{count}: {remedy}")
    return published[track]


def _check_parts(file: Path, track: str, part: Any, records: Sequence[Mapping[str, Any]],
                 protocol: Protocol) -> None:
    """Refuse a result whose `track` parts are not what its episodes' records give."""
    from lgmd_sim.benchmark import scores
    from lgmd_sim.benchmark.run import episode_score

    made = scores.parts_of(records, episode_score(track, protocol),
                           part.levels)
    if not (made.seeds == part.seeds and np.array_equal(made.sums, part.sums)):
        raise ValueError(f"{file}: its {track} parts are not what the episodes' records in "
                         f"{file.parent / track} give: the result or a record was changed")
