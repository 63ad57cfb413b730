"""The house's pool of local worker processes (`Pool`), on which
`lgmd_sim.core.parallel.run_jobs` runs jobs with ``workers`` above 1 or a pool given.

The workers end with the run (a `Pool`'s when it closes), whatever ends it: an error,
SIGTERM or Ctrl-C here stop them within seconds (SIGTERM, which lets a job remove its
temporaries, then SIGKILL), and they stop by themselves when this process ends, even
killed outright (on Linux at once, elsewhere after their job). The standard library's
pools do not: a killed worker unnamed or hanging the run, workers left running after the
parent's death or a stop (measured in docs/experiments/house.md), hence a pool of its own.

Apart from `lgmd_sim.core.parallel` because it is the one place that deals with processes,
signals and the parent's death; running jobs in this process or on Ray needs none of it.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from multiprocessing import resource_tracker
from multiprocessing.connection import Connection, wait
from multiprocessing.context import BaseContext
from multiprocessing.process import BaseProcess
from typing import Any

from lgmd_sim.core.jobs import Job, WorkerDied, _keeping
from lgmd_sim.core.params import checked, count
from lgmd_sim.core.stops import (
    STOPPING,
    catch_swallowed_stops,
    held_stops,
    stop_raised,
    stopping,
)

__all__ = ["Pool"]

#: Seconds the workers have to stop (their jobs' temporaries removed) before SIGKILL.
_GRACE = 3
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


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
    except Exception:
        if not stopping():
            raise
        # The stop came while a job's modules were imported (unpickling the job names
        # them): the import made it the ImportError it caused, which would be printed as
        # the worker's failure. It is the stop.
        raise SystemExit(128 + signal.SIGTERM) from None
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
        checked("workers", workers, count)
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
