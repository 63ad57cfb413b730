"""`lgmd-sim speed closed-loop`: what the detector and the controller add to an episode, and
how the benchmark scales with worker processes.

In one run, on the same scenario and frame size:

- steps per second of the environment alone (a fixed action), and of the environment
  with `ReactiveAvoid` driven by each model (the model on every frame, its S layer, the
  controller): the ratio is the share of the speed the detector leaves (target 0.9 or
  more: the LGMD and the controller cost at most 10%);
- episodes of ``lgmd-sim bench closed-loop`` (`lgmd_sim.bench.episode.episode`) on one
  and on two local workers, the same episodes: the speed-up (target 1.85x or more);
- the environment alone stepping as many frames per episode on two workers: the limit of
  the benchmark's two workers, of which they reach a share (target 0.9 or more).

Worker start-up is in the timed span of every pool, paid once per run: the workers keep
their environments from episode to episode (`lgmd_sim.parallel.kept`).
"""

from __future__ import annotations

import os
import time

import numpy as np

from lgmd_sim.machine import cpu_name
from lgmd_sim.speed import format_table

#: Steps before timing starts (GL context, first frames, JIT caches).
WARMUP = 10
#: The fixed action of the environment alone: what the avoider does while cruising.
ACTION = np.array([0.6, 0.0], np.float32)


def _steps_per_s(env, steps: int, controller=None) -> float:
    """Steps per second over `steps` steps, resets outside the timing."""
    obs, info = env.reset(seed=0)
    if controller is not None:
        controller.reset()
    elapsed, done = 0.0, -WARMUP
    while done < steps:
        start = time.perf_counter()
        action = ACTION if controller is None else controller.act(obs, info)
        obs, _, terminated, truncated, info = env.step(action)
        if done >= 0:
            elapsed += time.perf_counter() - start
        done += 1
        if terminated or truncated:
            obs, info = env.reset()
            if controller is not None:
                controller.reset()
    return steps / elapsed


def measure_overhead(scenario: str, resolution: str, models: list[str], steps: int
                     ) -> list[dict]:
    import gymnasium as gym

    from lgmd_sim import controllers
    from lgmd_sim.envs.catalogue import scenario as scenario_of

    env = gym.make(scenario_of(scenario).env_id, resolution=resolution)
    try:
        alone = _steps_per_s(env, steps)
        rows = [{"what": "environment alone", "steps_per_s": alone, "ratio": 1.0}]
        for name in models:
            rate = _steps_per_s(env, steps, controllers.make("reactive", model=name))
            rows.append({"what": f"+ ReactiveAvoid({name})", "steps_per_s": rate,
                         "ratio": rate / alone})
    finally:
        env.close()
    return rows


def bare_episode(scenario: str, jitter: float, resolution: str | list[int], seed: int,
                 frames: int) -> dict[str, int]:
    """The environment alone for `frames` frames (a fixed action, resetting where an
    episode ends), in the kept environment a benchmark episode runs in; its record holds
    its frames, as a benchmark episode's does."""
    from lgmd_sim.envs.reuse import episode_env

    with episode_env(scenario, jitter=jitter, resolution=resolution) as env:
        env.reset(seed=seed)
        for _ in range(frames - 1):
            _, _, terminated, truncated, _ = env.step(ACTION)
            if terminated or truncated:
                env.reset()
    return {"frames": frames}


def measure_workers(scenario: str, resolution: str | list[int], episodes: int) -> dict:
    """Frames per second of the closed-loop benchmark's episodes on one worker and on
    two, and of the environment alone stepping as many frames per episode on two: the
    limit the benchmark's workers would reach if the detector and the controller cost
    nothing. Each run as ``lgmd-sim bench`` runs its jobs (one worker: in this process;
    two: a pool, its start-up included)."""
    from lgmd_sim.bench.episode import Cell, episode
    from lgmd_sim.parallel import Job, run_jobs

    cell = Cell(scenario, 1.0, "reactive", "feedback", "paper")
    jobs = [Job(cell.key(s), episode, {"cell": cell, "seed": s, "resolution": resolution,
                                      "cruise": 0.6, "horizon": 2.0}) for s in range(episodes)]

    def frames_per_s(jobs: list[Job], workers: int) -> tuple[float, dict[str, int]]:
        frames: dict[str, int] = {}
        start = time.perf_counter()
        run_jobs(jobs, lambda job, record: frames.__setitem__(job.key, record["frames"]),
                 workers=workers, progress=False)
        return sum(frames.values()) / (time.perf_counter() - start), frames

    one, frames = frames_per_s(jobs, 1)
    two, _ = frames_per_s(jobs, 2)
    bare, _ = frames_per_s([Job(job.key, bare_episode, {
        "scenario": scenario, "jitter": cell.jitter, "resolution": resolution,
        "seed": job.kwargs["seed"], "frames": frames[job.key]}) for job in jobs], 2)
    return {"one": one, "two": two, "speedup": two / one, "bare": bare, "share": two / bare}


def run(*, scenario: str = "RoughTerrainObstacles", resolution: str | list[int] = "rl",
        steps: int = 600, episodes: int = 12, markdown: bool = False) -> int:
    """Measure and print the closed-loop speed tables (Markdown with `markdown`)."""
    from lgmd_sim import models

    names = models.available()
    overhead = measure_overhead(scenario, resolution, names, steps)
    workers = measure_workers(scenario, resolution, episodes)
    print(f"# lgmd-sim speed closed-loop: {scenario} at {resolution}, {steps} "
          f"steps per run, {episodes} episodes per worker count; CPU: {cpu_name()}, "
          f"{os.cpu_count()} cores")
    print(format_table(
        ["what", "steps/s", "share of the environment's speed"],
        [[r["what"], f"{r['steps_per_s']:.0f}", f"{r['ratio']:.2f}"] for r in overhead],
        markdown,
    ))
    print()
    print(format_table(
        ["closed-loop episodes", "1 worker frames/s", "2 workers frames/s", "speed-up",
         "environment alone, 2 workers frames/s", "share of the environment's speed"],
        [["ReactiveAvoid(feedback), jitter 1", f"{workers['one']:.0f}",
          f"{workers['two']:.0f}", f"{workers['speedup']:.2f}x", f"{workers['bare']:.0f}",
          f"{workers['share']:.2f}"]],
        markdown,
    ))
    return 0
