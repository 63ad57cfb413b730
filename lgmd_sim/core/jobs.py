"""What a job is to whatever runs it: the `Job`, the objects its process keeps for the
jobs after it (`kept`), and the error that names a job whose process died (`WorkerDied`).

What is costly to set up and can serve one job after another (an environment, with its
compiled scene and its GL context) a job takes from `kept`: made once in each process of
the run and handed to the run's later jobs there, so that a pool's throughput is that of
its episodes, not of their set-up.

Apart from `lgmd_sim.core.parallel` because every place a job runs shares them: this
process, a pool's worker and a Ray task each let `kept` keep while it runs jobs, and the
pool (`lgmd_sim.core.pool`), which `parallel.run_jobs` uses, takes them from here: from
`parallel` it would be an import cycle.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, TypeVar

__all__ = ["KEEP", "Job", "WorkerDied", "kept"]

T = TypeVar("T")


@dataclass(frozen=True)
class Job:
    """One unit of work: ``fn(**kwargs)``, named `key` (unique within a run).

    On a pool it runs in a daemonic process, which cannot start processes of its own with
    `multiprocessing` (subprocesses are fine)."""

    key: str
    fn: Callable[..., Any]
    kwargs: Mapping[str, Any] = field(default_factory=dict)


class WorkerDied(RuntimeError):
    """A worker process ended (killed, out of memory) while running a job."""


#: How many objects `kept` holds in one process: a benchmark's jobs come cell by cell, so
#: a few serve every episode of a run, and each kept environment holds its scene, its
#: frames and its GL buffers.
KEEP = 4
#: What `kept` holds in this process, the least recently used first; None outside a run
#: (a job called directly makes its objects and closes them when it is done).
_kept: OrderedDict[Hashable, Any] | None = None


@contextmanager
def kept(key: Hashable, make: Callable[[], T]) -> Iterator[T]:
    """``make()``, made once in this process of a run for `key` and kept for the run's
    later jobs with the same key.

    A job uses it for what is costly to set up and can serve job after job: an
    environment (its compiled scene, its GL context), which each job then resets with its
    own seed, so that its result is the same as with a fresh one (the tests show it for
    the jobs that use it). The least recently used of more than `KEEP` is closed (its
    ``close()``); the rest go when the run ends (an in-process run closes them; a pool's
    workers end). Outside `run_jobs` the object is made for this one use and closed after.
    """
    if _kept is None:
        obj = make()
        try:
            yield obj
        finally:
            _close(obj)
        return
    if key in _kept:
        _kept.move_to_end(key)
    else:
        _kept[key] = make()
        while len(_kept) > KEEP:
            _close(_kept.popitem(last=False)[1])
    yield _kept[key]


def _close(obj: Any) -> None:
    close = getattr(obj, "close", None)
    if close is not None:
        close()


@contextmanager
def _keeping() -> Iterator[None]:
    """Let `kept` keep its objects while this process runs jobs; close them after."""
    global _kept
    if _kept is not None:  # a run within a run's job: the outer one keeps them
        yield
        return
    _kept = OrderedDict()
    try:
        yield
    finally:
        held, _kept = _kept, None
        for obj in held.values():
            _close(obj)


def _call_keeping(fn: Callable[..., Any], kwargs: Mapping[str, Any]) -> Any:
    """A Ray task: its worker process lives on between tasks, and keeps `kept`'s objects."""
    global _kept
    if _kept is None:
        _kept = OrderedDict()
    return fn(**kwargs)
