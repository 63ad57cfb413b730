"""`episode_env`: the environment a job runs one episode in, made once in each process of a
run and handed to the run's later jobs there.

Making an environment compiles its scene and, at its first frame, makes a GL context: a
tenth of a second, paid per episode when each job made its own. A kept environment is
reset with the job's seed, and `JitterEnv.reset` rewrites everything an episode draws, so
the episode is bit-identical to one in a fresh environment (tests/core/test_reuse.py shows
it for the benchmark's, the dataset's and the calibration's episodes).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import gymnasium as gym

from lgmd_sim.core.jobs import kept
from lgmd_sim.envs.catalogue import scenario

__all__ = ["episode_env"]


@contextmanager
def episode_env(name: str, **overrides: Any) -> Iterator[gym.Env]:
    """``gym.make`` of catalogue scenario `name` with `overrides`, kept for the run's later
    episodes with the same arguments (`lgmd_sim.core.jobs.kept`); outside a run, made for
    this episode and closed after it. Reset it with the episode's seed; do not close it."""
    env_id = scenario(name).env_id
    key = ("episode_env", env_id, repr(sorted(overrides.items())))
    with kept(key, lambda: gym.make(env_id, **overrides)) as env:
        yield env
