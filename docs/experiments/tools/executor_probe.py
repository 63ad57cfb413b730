"""Why lgmd_sim.core.pool is a worker pool of its own: what the standard library's
`concurrent.futures.ProcessPoolExecutor` (spawn workers, this Python) does at the three
places the pool's hostile tests (tests/core/test_parallel.py, tests/cli/test_process_lifetime.py)
poke, and `multiprocessing.Pool` at one of them, printed as one line each. Recorded in
docs/experiments/house.md.

    .venv/bin/python docs/experiments/tools/executor_probe.py     # about 25 s
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

SPAWN = mp.get_context("spawn")


def nap(seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


def die(seconds: float) -> None:
    time.sleep(seconds)
    os.kill(os.getpid(), signal.SIGKILL)


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in "ZX"
    except OSError:
        return False


def a_killed_worker() -> str:
    """Two jobs running, one worker killed: which job does the error name?"""
    with cf.ProcessPoolExecutor(2, mp_context=SPAWN) as pool:
        running = {"a-naps": pool.submit(nap, 1.0), "b-dies": pool.submit(die, 0.3)}
        failed = []
        for key, future in running.items():
            try:
                future.result()
            except cf.process.BrokenProcessPool:
                failed.append(key)
    return (f"a worker killed with 2 jobs running: BrokenProcessPool for {failed} "
            "(the same message each; the job whose worker died is not named)")


def the_parent_killed() -> str:
    """The parent SIGKILLed while its workers run: are they left behind?"""
    code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
            "import concurrent.futures as cf, multiprocessing as mp, executor_probe as p; "
            "pool = cf.ProcessPoolExecutor(2, mp_context=mp.get_context('spawn')); "
            "jobs = [pool.submit(p.nap, 60) for _ in range(2)]; print('up', flush=True); "
            "jobs[0].result()")
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                              start_new_session=True)
    parent.stdout.readline()
    time.sleep(2)
    parent.kill()
    parent.wait()
    time.sleep(2)
    left = [int(p) for p in subprocess.run(["pgrep", "-s", str(parent.pid)], text=True,
                                           capture_output=True).stdout.split()]
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    return f"the parent SIGKILLed: {len(left)} of its processes still running 2 s later"


def a_killed_worker_of_multiprocessing_pool() -> str:
    """The same with `multiprocessing.Pool`: does the run learn of it at all?"""
    with SPAWN.Pool(2) as pool:
        job = pool.apply_async(die, (0.3,))
        try:
            job.get(timeout=10)
        except mp.TimeoutError:
            return ("multiprocessing.Pool, a worker killed: no error; the job's result "
                    "still awaited 10 s later (it replaces the worker and waits for ever)")
    return "multiprocessing.Pool, a worker killed: the run was told"


def a_stopped_run() -> str:
    """The run stopped (an error, Ctrl-C) while jobs run: does shutdown end them?"""
    pool = cf.ProcessPoolExecutor(2, mp_context=SPAWN)
    for _ in range(2):
        pool.submit(nap, 30)
    time.sleep(2)
    workers = list(pool._processes)  # private: the public API has no way to reach them
    pool.shutdown(wait=False, cancel_futures=True)
    time.sleep(1)
    alive = [pid for pid in workers if _alive(pid)]
    for pid in alive:
        os.kill(pid, signal.SIGKILL)
    return (f"shutdown(wait=False, cancel_futures=True) with 2 jobs running: {len(alive)} "
            "workers still running 1 s later")


if __name__ == "__main__":
    print(f"Python {sys.version.split()[0]}")
    for probe in (a_killed_worker, a_killed_worker_of_multiprocessing_pool, the_parent_killed,
                  a_stopped_run):
        print("-", probe())
