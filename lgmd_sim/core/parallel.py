"""Many independent jobs (episodes) on local worker processes or on Ray, same results.

A `lgmd_sim.core.jobs.Job` is a module-level function and its keyword arguments, named by
a unique key; its result must depend on those arguments only (seeds included), so that the
results are identical whatever runs them: this process (``workers=1``), a pool of worker
processes (`lgmd_sim.core.pool.Pool`), or Ray tasks. `run_jobs` hands each result to
``on_result`` in this process as soon as its job finishes, so the caller stores it at once
(atomically) and an interrupted run keeps every finished job; calling it again with the
rest resumes.

What is costly to set up and can serve one job after another a job takes from
`lgmd_sim.core.jobs.kept`. A `lgmd_sim.core.pool.Pool` keeps its workers, and so what they
keep, from one `run_jobs` call to the next.

>>> from lgmd_sim.core.jobs import Job
>>> from lgmd_sim.core.parallel import RunOptions, run_jobs
>>> jobs = [Job(f"seed{s}", my_episode, {"seed": s}) for s in range(50)]
>>> run_jobs(jobs, lambda job, result: store(job.key, result), RunOptions(workers=2))
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from lgmd_sim.core.jobs import Job, WorkerDied, _call_keeping, _keeping
from lgmd_sim.core.params import checked, count, optional
from lgmd_sim.core.pool import Pool

__all__ = ["RunOptions", "default_workers", "run_jobs"]


@dataclass(frozen=True)
class RunOptions:
    """How a job runs, never what it computes: every job's results are the same whatever
    these are. Checked when made, so that a bad value fails before any work starts.

    Args:
        workers: local worker processes (None: every core; 1: in this process, in order).
        ray_address: run the jobs as Ray tasks instead: "local" starts a Ray instance on
            this machine, "auto" or [ray://]HOST:PORT joins a running cluster (needs the
            ``ray`` extra); checked to answer (`check_ray_address`).
        progress: show a progress bar on stderr (None: only on a terminal).
        resume: complete the run in the job's folder (the same configuration): its
            finished jobs are kept.
        command: the command line, for the run's record.
    """

    workers: int | None = None
    ray_address: str | None = None
    progress: bool | None = None
    resume: bool = False
    command: str = ""

    def __post_init__(self) -> None:
        checked("workers", self.workers, optional(count))
        if self.ray_address is not None:
            check_ray_address(self.ray_address)


def default_workers() -> int:
    """Worker processes to use by default: every core this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


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


def run_jobs(jobs: Sequence[Job], on_result: Callable[[Job, Any], None],
             options: RunOptions = RunOptions(), *, pool: Pool | None = None,
             desc: str = "running", unit: str = "episode",
             count: Callable[[Any], int] | None = None, item_unit: str = "frame") -> None:
    """Run every job; call ``on_result(job, result)`` here as each finishes.

    Args:
        jobs: the jobs, keys unique.
        on_result: stores a result; called in this process, one call at a time.
        options: where the jobs run (workers, Ray) and whether a progress bar shows.
        pool: run the jobs on this started `Pool` (not with `options.workers` or
            `options.ray_address`), which stays up for the caller's next runs.
        desc, unit: the progress bar's label and what a job is called.
        count: the number of items (frames) in a result: the bar then shows items/s too.
        item_unit: what an item is called.

    Raises:
        WorkerDied: a worker ended while running a job (the job is named); the results
            of the jobs that finished before have been handed to ``on_result``.
        ValueError: duplicate keys, or `pool` with `options.workers` or
            `options.ray_address`.
    """
    keys = [job.key for job in jobs]
    if len(set(keys)) != len(keys):
        raise ValueError("run_jobs: job keys must be unique")
    workers, ray_address = options.workers, options.ray_address
    if pool is not None and (workers is not None or ray_address is not None):
        raise ValueError("run_jobs: a pool runs the jobs on its own workers: give pool, "
                         "or workers or ray_address, not both")
    if not jobs:
        return
    bar = _Progress(len(jobs), desc, unit, options.progress, item_unit if count else None)

    def store(job: Job, result: Any) -> None:
        on_result(job, result)
        bar.advance(count(result) if count else 0)

    try:
        if pool is not None:
            pool.run(jobs, store)
        elif ray_address is not None:
            _run_on_ray(jobs, store, ray_address)
        elif (workers or default_workers()) == 1 or len(jobs) == 1:
            with _keeping():
                for job in jobs:
                    store(job, job.fn(**job.kwargs))
        else:
            with Pool(min(workers or default_workers(), len(jobs))) as own:
                own.run(jobs, store)
    finally:
        bar.close()


#: How long a Ray cluster's HOST:PORT may take to answer before it is taken for none (s).
RAY_CONNECT_TIMEOUT_S = 10.0


def check_ray_address(address: str) -> str:
    """`address` as `RunOptions.ray_address` takes it (the command line's ``--workers ray``,
    from the RAY_ADDRESS variable): "local", "auto" or [ray://]HOST:PORT, whose port
    answers within `RAY_CONNECT_TIMEOUT_S` (Ray itself retries an address that does not
    for ever).

    Raises:
        ValueError: another form, or an address where nothing answers, in one line.
    """
    import socket

    if address in ("local", "auto"):
        return address
    host, colon, port = address.removeprefix("ray://").rpartition(":")
    if not (colon and host and port.isdigit() and 0 < int(port) < 65536):
        raise ValueError(f"Ray address {address!r}: give local, auto or HOST:PORT")
    try:
        socket.create_connection((host.strip("[]"), int(port)), RAY_CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise ValueError(f"Ray address {address}: no Ray cluster answers there "
                         f"({exc.strerror or exc}): start one with `ray start --head`, or "
                         "run Ray here (RAY_ADDRESS unset, ray_address 'local')") from None
    return address


def _run_on_ray(jobs: Sequence[Job], on_result: Callable[[Job, Any], None], address: str
                ) -> None:
    from lgmd_sim.core.extras import require
    from lgmd_sim.core.numerics import mode, pinned_environment

    ray = require("ray", "ray")
    started = not ray.is_initialized()
    pending: dict[Any, Job] = {}
    if started:
        try:
            # the workers compute in this process's numeric mode (lgmd_sim.core.numerics)
            env = pinned_environment() if mode() == "replay" else {}
            ray.init(address=None if address == "local" else check_ray_address(address),
                     include_dashboard=False, log_to_driver=False, configure_logging=False,
                     runtime_env={"env_vars": env} if env else None)
        except ConnectionError as exc:  # "auto" with no cluster to find
            raise ValueError(f"Ray address {address}: {exc}") from None
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(_call_keeping)
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
