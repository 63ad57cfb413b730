"""Many independent jobs (episodes) on local worker processes or on Ray, same results.

A `Job` is a module-level function and its keyword arguments, named by a unique key; its
result must depend on those arguments only (seeds included), so that the results are
identical whatever runs them: this process (``workers=1``), a pool of worker processes,
or Ray tasks. `run_jobs` hands each result to ``on_result`` in this process as soon as
its job finishes, so the caller stores it at once (atomically) and an interrupted run
keeps every finished job; calling it again with the rest resumes.

>>> from lgmd_sim.parallel import Job, run_jobs
>>> jobs = [Job(f"seed{s}", my_episode, {"seed": s}) for s in range(50)]
>>> run_jobs(jobs, lambda job, result: store(job.key, result), workers=2)
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Job", "WorkerDied", "default_workers", "run_jobs"]


@dataclass(frozen=True)
class Job:
    """One unit of work: ``fn(**kwargs)``, named `key` (unique within a run)."""

    key: str
    fn: Callable[..., Any]
    kwargs: Mapping[str, Any] = field(default_factory=dict)


class WorkerDied(RuntimeError):
    """A worker process ended (killed, out of memory) while running a job."""


def default_workers() -> int:
    """Worker processes to use by default: every core this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _call(fn: Callable[..., Any], kwargs: Mapping[str, Any]) -> Any:
    return fn(**kwargs)


class _Progress:
    """A progress bar: jobs done, jobs per minute, time left; optionally items per second
    (the frames of episodes), counted from each result."""

    def __init__(self, total: int, desc: str, unit: str, enabled: bool | None,
                 item_unit: str | None = None) -> None:
        from tqdm import tqdm

        self.start = time.monotonic()
        self.bar = tqdm(total=total, desc=desc, file=sys.stderr,
                        disable=None if enabled is None else not enabled,
                        leave=False, bar_format="{desc}: {n}/{total} " + unit + "s "
                        "|{bar}| {postfix}")
        self.unit = unit
        self.item_unit = item_unit
        self.items = 0

    def advance(self, items: int = 0) -> None:
        self.bar.update()
        self.items += items
        seconds = time.monotonic() - self.start
        rate = 60 * self.bar.n / seconds if seconds > 0 else 0.0
        left = (self.bar.total - self.bar.n) / rate if rate > 0 else float("nan")
        per_s = (f", {self.items / seconds:.0f} {self.item_unit}s/s"
                 if self.item_unit and seconds > 0 else "")
        self.bar.set_postfix_str(f"{rate:.1f} {self.unit}s/min{per_s}, {left:.1f} min left")

    def close(self) -> None:
        self.bar.close()


def run_jobs(jobs: Sequence[Job], on_result: Callable[[Job, Any], None], *,
             workers: int | None = None, ray_address: str | None = None,
             progress: bool | None = None, desc: str = "running", unit: str = "episode",
             count: Callable[[Any], int] | None = None, item_unit: str = "frame") -> None:
    """Run every job; call ``on_result(job, result)`` here as each finishes.

    Args:
        jobs: the jobs, keys unique.
        on_result: stores a result; called in this process, one call at a time.
        workers: local worker processes (default: every core); 1 runs the jobs in this
            process, in order.
        ray_address: run the jobs as Ray tasks instead: "local" starts a Ray instance
            on this machine, "auto" or "HOST:PORT" joins a running cluster (needs the
            ``ray`` extra).
        progress: show a progress bar on stderr (None: only on a terminal).
        desc, unit: the progress bar's label and what a job is called.
        count: the number of items (frames) in a result: the bar then shows items/s too.
        item_unit: what an item is called.

    Raises:
        WorkerDied: a worker ended while running a job (the job is named); the results
            of the jobs that finished before have been handed to ``on_result``.
        ValueError: duplicate keys, or a bad ``workers`` value.
    """
    keys = [job.key for job in jobs]
    if len(set(keys)) != len(keys):
        raise ValueError("run_jobs: job keys must be unique")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if not jobs:
        return
    bar = _Progress(len(jobs), desc, unit, progress, item_unit if count else None)

    def store(job: Job, result: Any) -> None:
        on_result(job, result)
        bar.advance(count(result) if count else 0)

    try:
        if ray_address is not None:
            _run_on_ray(jobs, store, ray_address)
        elif (workers or default_workers()) == 1 or len(jobs) == 1:
            for job in jobs:
                store(job, _call(job.fn, job.kwargs))
        else:
            _run_on_pool(jobs, store, min(workers or default_workers(), len(jobs)))
    finally:
        bar.close()


def _run_on_pool(jobs: Sequence[Job], on_result: Callable[[Job, Any], None], workers: int
                 ) -> None:
    # Fresh interpreters (spawn): a fork would copy this process's threads and GL state.
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
    pending: dict[Future, Job] = {}
    queue = list(reversed(jobs))
    try:
        while queue or pending:
            while queue and len(pending) < 2 * workers:  # a few queued ahead, not all
                job = queue.pop()
                pending[pool.submit(_call, job.fn, job.kwargs)] = job
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in sorted(done, key=lambda f: pending[f].key):
                if isinstance(future.exception(), BrokenProcessPool):
                    lost = ", ".join(sorted(j.key for f, j in pending.items() if f.done()))
                    raise WorkerDied(f"a worker process died (killed, or out of memory) "
                                     f"while running one of: {lost}") from future.exception()
                job = pending.pop(future)
                on_result(job, future.result())
    finally:
        for future in pending:
            future.cancel()
        _shutdown(pool)


def _shutdown(pool: ProcessPoolExecutor) -> None:
    """Stop the workers now, also those busy with a job (after an error or Ctrl-C)."""
    processes = list((pool._processes or {}).values())  # no public way to stop a busy one
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(5)


def _run_on_ray(jobs: Sequence[Job], on_result: Callable[[Job, Any], None], address: str
                ) -> None:
    from lgmd_sim.extras import require

    ray = require("ray", "ray")
    started = not ray.is_initialized()
    pending: dict[Any, Job] = {}
    if started:
        ray.init(address=None if address == "local" else address, include_dashboard=False,
                 log_to_driver=False, configure_logging=False)
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(_call)
        pending.update({task.remote(job.fn, job.kwargs): job for job in jobs})
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            job = pending.pop(ready[0])
            try:
                result = ray.get(ready[0])
            except ray.exceptions.WorkerCrashedError as exc:
                raise WorkerDied(f"a Ray worker died while running {job.key}") from exc
            on_result(job, result)
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()
