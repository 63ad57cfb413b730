"""Vector environments the project makes itself: async workers that say which one died.

Gymnasium's `AsyncVectorEnv` reports a worker killed from outside (out of memory, a
signal) as a bare ``EOFError`` or ``BrokenPipeError``. `WorkerAsyncVectorEnv` turns that
into a RuntimeError naming the worker, its process id and how it ended.

>>> from lgmd_sim.envs.vector import make_async
>>> envs = make_async("lgmd_sim/PassBy-v0", 2, resolution="small")
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import gymnasium as gym
from gymnasium.vector import AsyncVectorEnv

from lgmd_sim.core.params import checked, count

__all__ = ["WorkerAsyncVectorEnv", "make_async"]

_LOST = (EOFError, BrokenPipeError, ConnectionResetError)


class WorkerAsyncVectorEnv(AsyncVectorEnv):
    """`AsyncVectorEnv` whose lost workers are named in the error."""

    def step(self, actions: Any) -> Any:
        with self._named_worker_deaths():
            return super().step(actions)

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None) -> Any:
        with self._named_worker_deaths():
            return super().reset(seed=seed, options=options)

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        with self._named_worker_deaths():
            return super().call(name, *args, **kwargs)

    @contextlib.contextmanager
    def _named_worker_deaths(self) -> Iterator[None]:
        try:
            yield
        except _LOST as exc:
            dead = []
            for index, process in enumerate(self.processes):
                process.join(timeout=1.0)
                if process.exitcode is not None:
                    code = process.exitcode
                    how = f"killed by signal {-code}" if code < 0 else f"exited with status {code}"
                    dead.append(f"worker {index} (pid {process.pid}) {how}")
            what = "; ".join(dead) or "a worker stopped answering"
            raise RuntimeError(f"async vector environment: {what}") from exc


def make_async(env_id: str, num_envs: int, *,
               wrappers: Sequence[Callable[[gym.Env], gym.Env]] = (),
               **kwargs: Any) -> WorkerAsyncVectorEnv:
    """`num_envs` copies of ``gym.make(env_id, **kwargs)`` (each wrapped by `wrappers`, in
    order) in worker processes, each with its own GL context."""
    checked("num_envs", num_envs, count)

    def make() -> gym.Env:
        env = gym.make(env_id, **kwargs)
        for wrap in wrappers:
            env = wrap(env)
        return env

    return WorkerAsyncVectorEnv([make] * num_envs)
