"""`lgmd-sim speed closed-loop`: what the detector and the controller add to an episode, and
how the benchmark scales with worker processes.

In one run, on the same scenario and frame size:

- steps per second of the environment alone (a fixed action), and of the environment
  with `ReactiveAvoid` driven by each model (the model on every frame, its S layer, the
  controller): the ratio is the share of the speed the detector leaves (target 0.9 or
  more: the LGMD and the controller cost at most 10%);
- episodes of ``lgmd-sim bench closed-loop`` (`lgmd_sim.bench.episode.episode`) on one
  and on two local workers, the same episodes: the speed-up (target 1.7x or more).
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


def measure_workers(scenario: str, resolution: str, episodes: int) -> dict:
    """Episodes per minute of the closed-loop benchmark on one and on two workers."""
    from lgmd_sim.bench.episode import Cell, episode
    from lgmd_sim.parallel import Job, run_jobs

    cell = Cell(scenario, 1.0, "reactive", "feedback", "paper")
    jobs = [Job(cell.key(s), episode, {"cell": cell, "seed": s, "resolution": resolution,
                                      "cruise": 0.6, "horizon": 2.0}) for s in range(episodes)]
    rates = {}
    for workers in (1, 2):
        frames = 0

        def count(job, record) -> None:
            nonlocal frames
            frames += record["frames"]

        start = time.perf_counter()
        run_jobs(jobs, count, workers=workers, progress=False)
        rates[workers] = frames / (time.perf_counter() - start)
    return {"one": rates[1], "two": rates[2], "speedup": rates[2] / rates[1]}


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
        ["closed-loop episodes", "1 worker frames/s", "2 workers frames/s", "speed-up"],
        [["ReactiveAvoid(feedback), jitter 1", f"{workers['one']:.0f}",
          f"{workers['two']:.0f}", f"{workers['speedup']:.2f}x"]],
        markdown,
    ))
    return 0
