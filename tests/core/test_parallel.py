"""lgmd_sim.core.parallel: the same results in process and on a pool; a dead worker named; a
Pool's workers kept from run to run."""

from __future__ import annotations

import os
import signal

import pytest

from lgmd_sim.core.jobs import Job, WorkerDied
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.core.pool import Pool


def square(x: int) -> dict[str, int]:  # importable by spawned workers (tests/ is on sys.path)
    return {"x": x, "square": x * x, "pid": os.getpid()}


def die(x: int) -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _collect(jobs, pool=None, **options) -> dict[str, dict]:
    results: dict[str, dict] = {}
    run_jobs(jobs, lambda job, r: results.__setitem__(job.key, r),
             RunOptions(progress=False, **options), pool=pool)
    return results


def test_pool_gives_the_results_of_a_single_process():
    jobs = [Job(f"j{x:02d}", square, {"x": x}) for x in range(12)]
    one = _collect(jobs, workers=1)
    two = _collect(jobs, workers=2)
    assert {k: v["square"] for k, v in one.items()} == {k: v["square"] for k, v in two.items()}
    assert {v["pid"] for v in one.values()} == {os.getpid()}
    assert len({v["pid"] for v in two.values()}) == 2 and os.getpid() not in {
        v["pid"] for v in two.values()}


def test_a_killed_worker_is_named_and_earlier_results_are_kept():
    jobs = [Job("a-first", square, {"x": 1}), Job("b-dies", die, {"x": 2})]
    got: list[str] = []
    with pytest.raises(WorkerDied, match="b-dies"):
        run_jobs(jobs, lambda job, r: got.append(job.key), RunOptions(workers=2, progress=False))
    assert got in ([], ["a-first"])  # a-first may or may not have finished first


def test_bad_arguments():
    with pytest.raises(ValueError, match="unique"):
        run_jobs([Job("a", square, {"x": 1})] * 2, lambda *a: None)
    with pytest.raises(ValueError, match="workers"):
        run_jobs([Job("a", square, {"x": 1})], lambda *a: None, RunOptions(workers=0))


def test_a_pool_keeps_its_workers_from_run_to_run():
    with Pool(2) as pool:
        first = _collect([Job(f"a{x}", square, {"x": x}) for x in range(4)], pool=pool)
        second = _collect([Job(f"b{x}", square, {"x": x}) for x in range(4)], pool=pool)
    assert {k[1:]: v["square"] for k, v in first.items()} == {
        k[1:]: v["square"] for k, v in second.items()}
    pids = {v["pid"] for v in first.values()}
    assert len(pids) == 2 and {v["pid"] for v in second.values()} == pids


def test_a_failed_run_closes_its_pool():
    with Pool(2) as pool:
        with pytest.raises(WorkerDied, match="dies"):
            _collect([Job("dies", die, {"x": 0})], pool=pool)
        with pytest.raises(RuntimeError, match="closed"):
            _collect([Job("after", square, {"x": 1})], pool=pool)


def test_a_pool_is_not_given_with_workers_or_ray():
    with Pool(1) as pool:
        with pytest.raises(ValueError, match="not both"):
            run_jobs([Job("a", square, {"x": 1})], lambda *a: None, RunOptions(workers=2),
                     pool=pool)
    with pytest.raises(ValueError, match="workers"):
        Pool(0)
