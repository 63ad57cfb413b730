"""Objects kept across a run's jobs (`lgmd_sim.core.jobs.kept`) and the environments kept
for episodes (`lgmd_sim.envs.reuse`): an episode in a kept environment is bit-identical
to one in a fresh environment, for the benchmark's, the dataset's and the calibration's
episodes, whatever ran in that environment before."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from lgmd_sim.benchmark.episode import Cell, episode
from lgmd_sim.calibration import clips
from lgmd_sim.core import jobs
from lgmd_sim.core.jobs import Job, kept
from lgmd_sim.core.parallel import RunOptions, run_jobs


class Thing:
    made: ClassVar[list[Thing]] = []

    def __init__(self, key: str) -> None:
        self.key, self.closed = key, False
        Thing.made.append(self)

    def close(self) -> None:
        self.closed = True


def use(key: str) -> int:
    with kept(key, lambda: Thing(key)) as thing:
        assert not thing.closed
        return id(thing)


def _in_a_run(fn, calls: list[dict]) -> list:
    """`fn(**kwargs)` of every call, as the jobs of one in-process run, in order."""
    out: dict[str, object] = {}
    run_jobs([Job(f"{i:03d}", fn, kw) for i, kw in enumerate(calls)],
             lambda job, result: out.__setitem__(job.key, result),
             RunOptions(workers=1, progress=False))
    return [out[f"{i:03d}"] for i in range(len(calls))]


def test_a_run_keeps_one_object_per_key_and_closes_them_when_it_ends(monkeypatch):
    Thing.made.clear()
    ids = _in_a_run(use, [{"key": k} for k in "aabab"])
    assert ids[0] == ids[1] == ids[3] and ids[2] == ids[4] != ids[0]
    assert len(Thing.made) == 2 and all(t.closed for t in Thing.made)

    Thing.made.clear()
    monkeypatch.setattr(jobs, "KEEP", 1)  # room for one: the other is closed to make room
    _in_a_run(use, [{"key": k} for k in "aba"])
    assert [t.key for t in Thing.made] == ["a", "b", "a"] and all(t.closed for t in Thing.made)

    Thing.made.clear()
    use("a"), use("a")  # outside a run: made for each use, closed after it
    assert len(Thing.made) == 2 and all(t.closed for t in Thing.made)


@pytest.mark.slow
def test_benchmark_episodes_in_a_kept_environment_are_those_of_a_fresh_one():
    # two controllers take turns in one environment; the rough ground (heightfields sent to
    # a live renderer) between them
    cells = [Cell("StationaryApproach", 1.0, "reactive", "lgmd1", "published"),
             Cell("StationaryApproach", 1.0, "oracle"),
             Cell("RoughTerrainObstacles", 2.0, "straight")]
    calls = [{"cell": cell, "seed": seed, "resolution": "small", "cruise": 0.6,
              "horizon": 2.0, "top_view": True} for seed in (1000, 1001) for cell in cells]
    fresh = [episode(**kw) for kw in calls]  # records: JSON, non-finite numbers None
    assert _in_a_run(episode, calls) == fresh
    assert len({r["frames"] for r in fresh}) > 1  # different episodes, not one repeated


@pytest.mark.slow
def test_dataset_episodes_and_calibration_clips_in_a_kept_environment(tmp_path):
    pytest.importorskip("pyarrow")
    from lgmd_sim.data.episode import make_episode
    from lgmd_sim.data.generate import GenerateConfig

    config = GenerateConfig(("RoughTerrainObstacles", "PassBy"), (1.0,), 2, (32, 48),
                            models=("feedback",), overrides={"time_limit": 1.0})
    specs = [{"spec": s} for s in config.specs()]
    fresh = [make_episode(**kw) for kw in specs]
    for a, b in zip(_in_a_run(make_episode, specs), fresh, strict=True):
        assert (a.video, a.data) == (b.video, b.data)

    calls = [{"spec": clips.ClipSpec("near_miss", "PassBy", j, seed), "resolution": "small",
              "folder": str(tmp_path / where)} for seed in (3, 4) for j in (0.0, 1.0)
             for where in ("fresh", "kept")]
    for where in ("fresh", "kept"):
        (tmp_path / where).mkdir()
    labels = [clips.record_clip(**kw) for kw in calls[::2]]
    assert _in_a_run(clips.record_clip, calls[1::2]) == labels
    for kw in calls[::2]:
        key = kw["spec"].key
        with np.load(tmp_path / "fresh" / f"{key}.npz") as a, \
                np.load(tmp_path / "kept" / f"{key}.npz") as b:
            assert a.files == b.files
            for name in a.files:
                assert np.array_equal(a[name], b[name], equal_nan=True), (key, name)
