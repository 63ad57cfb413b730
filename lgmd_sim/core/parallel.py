"""Many independent jobs (episodes) on local worker processes or on Ray, same results.

A `Job` is a module-level function and its keyword arguments, named by a unique key; its
result must depend on those arguments only (seeds included), so that the results are
identical whatever runs them: this process (``workers=1``), a pool of worker processes,
or Ray tasks. `run_jobs` hands each result to ``on_result`` in this process as soon as
its job finishes, so the caller stores it at once (atomically) and an interrupted run
keeps every finished job; calling it again with the rest resumes.

What is costly to set up and can serve one job after another (an environment, with its
compiled scene and its GL context) a job takes from `kept`: made once in each process of
the run and handed to the run's later jobs there, so that a pool's throughput is that of
its episodes, not of their set-up. A `Pool` keeps its workers, and so what they keep,
from one `run_jobs` call to the next.

The workers end with the run (a `Pool`'s when it closes), whatever ends it: an error,
SIGTERM or Ctrl-C here stop them within seconds (SIGTERM, which lets a job remove its
temporaries, then SIGKILL), and they stop by themselves when this process ends, even
killed outright (on Linux at once, elsewhere after their job). The standard library's
pools do not: a killed worker unnamed or hanging the run, workers left running after the
parent's death or a stop (measured in docs/experiments/house.md), hence a pool of its own.

>>> from lgmd_sim.core.parallel import Job, run_jobs
>>> jobs = [Job(f"seed{s}", my_episode, {"seed": s}) for s in range(50)]
>>> run_jobs(jobs, lambda job, result: store(job.key, result), RunOptions(workers=2))
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import time
import traceback
from collections import OrderedDict, deque
from collections.abc import Callable, Hashable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from multiprocessing import resource_tracker
from multiprocessing.connection import Connection, wait
from multiprocessing.context import BaseContext
from multiprocessing.process import BaseProcess
from typing import Any, TypeVar

from lgmd_sim.core.stops import STOPPING, catch_swallowed_stops, held_stops, stop_raised

__all__ = ["KEEP", "Job", "Pool", "RunOptions", "WorkerDied", "default_workers", "kept",
           "run_jobs"]

T = TypeVar("T")

#: Seconds the workers have to stop (their jobs' temporaries removed) before SIGKILL.
_GRACE = 3
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


@dataclass(frozen=True)
class Job:
    """One unit of work: ``fn(**kwargs)``, named `key` (unique within a run).

    On a pool it runs in a daemonic process, which cannot start processes of its own with
    `multiprocessing` (subprocesses are fine)."""

    key: str
    fn: Callable[..., Any]
    kwargs: Mapping[str, Any] = field(default_factory=dict)


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
        workers = self.workers
        if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool)
                                    or workers < 1):
            raise ValueError(f"workers must be a positive integer, got {workers!r}")
        if self.ray_address is not None:
            check_ray_address(self.ray_address)


class WorkerDied(RuntimeError):
    """A worker process ended (killed, out of memory) while running a job."""


def default_workers() -> int:
    """Worker processes to use by default: every core this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


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


class _RemoteTraceback(Exception):
    """Where in its worker a job raised: the cause of the exception raised here."""


def _worker(conn: Connection, parent: int) -> None:
    """A worker process: runs each job that comes on `conn` and sends its result back,
    until the parent (process `parent`) closes its end, or ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the
    signal.signal(signal.SIGTERM, _stop_worker)  # parent alone decides, and stops us
    catch_swallowed_stops({SystemExit: signal.SIGTERM})
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPPING)
    if sys.platform.startswith("linux"):
        import ctypes

        # Stopped as soon as the parent ends, even killed outright; elsewhere a worker
        # ends after its job, when it finds the parent's end of the pipe closed.
        ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
        if os.getppid() != parent:  # it ended before that
            return
    try:
        with _keeping():
            _serve(conn)
    finally:  # nothing left to unwind: a SIGTERM while the interpreter ends just ends it
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _serve(conn: Connection) -> None:
    while True:
        try:
            fn, kwargs = conn.recv()
        except EOFError:
            return
        try:
            reply = (True, fn(**kwargs))
        except Exception as exc:  # raised in the parent, with this traceback as its cause
            reply = (False, exc, traceback.format_exc())
        try:
            conn.send(reply)
        except OSError:  # the parent is gone
            return
        except Exception as exc:  # a result or exception that cannot be pickled
            conn.send((False, RuntimeError(f"a {type(reply[1]).__name__} cannot be sent "
                                           f"back from its worker: {exc}"),
                       traceback.format_exc()))


def _stop_worker(signum: int, frame: object) -> None:
    # The job unwinds (its `finally`s and `with`s remove its temporaries) within the
    # grace: then SIGALRM's default action ends the process.
    if not signal.getitimer(signal.ITIMER_REAL)[0]:
        signal.alarm(_GRACE)
    stop_raised()
    raise SystemExit(128 + signum)


@dataclass
class _Worker:
    """A worker process, our end of its pipe, and the job it is running (None: idle)."""

    process: BaseProcess
    conn: Connection
    job: Job | None = None

    def send(self, job: Job) -> None:
        try:
            self.conn.send((job.fn, job.kwargs))
        except OSError:  # its end of the pipe is closed: it died between two jobs
            raise WorkerDied(f"a worker process died (killed, or out of memory) before "
                             f"running {job.key}") from None
        self.job = job

    def receive(self) -> Any:
        """The result of the running job (raising its exception)."""
        # Only the worker holds the other end: an end of file (or a reset, where it had a
        # job unread) is its death.
        try:
            ok, value, *trace = self.conn.recv()
        except (EOFError, OSError):
            raise WorkerDied(f"a worker process died (killed, or out of memory) while "
                             f"running {self.job.key}") from None
        if not ok:
            raise value from _RemoteTraceback(trace[0])
        return value


def _start_worker(context: BaseContext, pool: list[_Worker]) -> None:
    ours, theirs = context.Pipe()
    process = context.Process(target=_worker, args=(theirs, os.getpid()), daemon=True,
                              name=f"lgmd-sim worker {len(pool) + 1}")
    # The worker starts with these blocked, until its handlers are in place (a Ctrl-C
    # while it starts would print its traceback); here they wait until the worker is in
    # `pool`, whose workers _stop ends: a stop half-way through its start would leave it
    # reading its start-up data from a closed pipe, and printing that traceback. The first
    # start of a process would also start multiprocessing's resource tracker, which unblocks
    # them as it does: that is done before.
    resource_tracker.ensure_running()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOPPING)
    try:
        with held_stops():
            process.start()
            pool.append(_Worker(process, ours))
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    theirs.close()  # its end is the worker's alone, so that its death is an end of file


class Pool:
    """Local worker processes that live across runs: each started once (a fresh
    interpreter, its imports, and through `kept` its environments with their GL
    contexts), then given the jobs of one `run_jobs` call after another, so that a job
    that comes later pays no start-up. `run_jobs` with ``workers=N`` starts one for its
    own jobs; pass one as ``pool=`` to share it between calls (a job's two phases) or to
    start it before a timed span. An error or a stop during a run ends its workers: the
    pool is then closed, and a later run raises.

    >>> with Pool(2) as pool:
    ...     run_jobs(clips, store_clip, pool=pool)
    ...     run_jobs(scores, store_score, pool=pool)  # the same two processes
    """

    def __init__(self, workers: int) -> None:
        if not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers must be a positive integer, got {workers!r}")
        # Fresh interpreters (spawn): a fork would copy this process's threads and GL
        # state. One pipe per worker and no threads here: a signal ends the run at once,
        # and a worker dying part-way through sending a result is an end of file, never a
        # hang.
        context = multiprocessing.get_context("spawn")
        self._workers: list[_Worker] = []
        self._closed = False
        try:
            for _ in range(workers):
                _start_worker(context, self._workers)
        except BaseException:
            self.close()
            raise

    @property
    def size(self) -> int:
        """Its number of worker processes."""
        return len(self._workers)

    def run(self, jobs: Sequence[Job], on_result: Callable[[Job, Any], None]) -> None:
        """Every job on the workers, ``on_result(job, result)`` here as each finishes."""
        if self._closed:
            raise RuntimeError("this Pool is closed (its run failed or it was closed)")
        queue = deque(jobs)
        ok = False
        try:
            while queue or any(worker.job is not None for worker in self._workers):
                # A job to each idle worker, none queued behind a running one: at the end
                # of a run a worker would wait idle while another still had two jobs.
                for worker in self._workers:
                    if queue and worker.job is None:
                        worker.send(queue.popleft())
                ready = wait([w.conn for w in self._workers if w.job is not None])
                for worker in sorted((w for w in self._workers if w.conn in ready),
                                     key=lambda w: w.job.key):
                    result = worker.receive()
                    job, worker.job = worker.job, None
                    on_result(job, result)
            ok = True
        finally:
            if not ok:
                self.close()

    def close(self) -> None:
        """End the workers (those busy with a job too); closing again does nothing."""
        if not self._closed:
            self._closed = True
            _stop(self._workers)

    def __enter__(self) -> Pool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _stop(pool: Sequence[_Worker]) -> None:
    """End the workers, also those busy with a job (after an error, SIGTERM or Ctrl-C):
    SIGTERM, then SIGKILL for any still there after the grace."""
    for worker in pool:
        worker.conn.close()  # an idle worker ends at that
        if worker.job is not None:
            worker.process.terminate()
    deadline = time.monotonic() + _GRACE + 1
    for worker in pool:
        worker.process.join(max(0.0, deadline - time.monotonic()))
        if worker.process.exitcode is None:
            worker.process.kill()
            worker.process.join(1)


#: How long a Ray cluster's HOST:PORT may take to answer before it is taken for none (s).
RAY_CONNECT_TIMEOUT_S = 10.0


def check_ray_address(address: str) -> str:
    """`address` as ``--ray`` takes it: "local", "auto" or [ray://]HOST:PORT, whose port
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
        raise ValueError(f"--ray {address!r}: give local, auto or HOST:PORT")
    try:
        socket.create_connection((host.strip("[]"), int(port)), RAY_CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise ValueError(f"--ray {address}: no Ray cluster answers there "
                         f"({exc.strerror or exc}): start one with `ray start "
                         "--head`, or give --ray local") from None
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
            raise ValueError(f"--ray {address}: {exc}") from None
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
