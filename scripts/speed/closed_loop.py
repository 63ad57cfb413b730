"""`python -m scripts.speed closed-loop`: what the detector and the controller add to an
episode, and how the benchmark scales with worker processes.

In one run, on the same scenario and frame size:

- steps per second of the environment driven by `ReactiveAvoid` with each model (the
  model on every frame, its S layer, the controller), and the share of that time the
  environment's step takes, timed apart on the same steps (target 0.9 or more: the LGMD
  and the controller cost at most 10%). Timed apart, since an environment driven
  otherwise (a fixed action) goes elsewhere and renders other views: its own speed
  differed from the controller's runs by as much as the shares to be measured;
- episodes of ``lgmd-sim bench closed-loop`` (`lgmd_sim.benchmark.episode.episode`) on one
  and on two local workers, the same episodes: the speed-up (target 1.85x or more);
- the environment alone stepping as many frames per episode, on one and on two workers:
  its own speed-up, the limit of the benchmark's, and the share of its two workers'
  speed the benchmark's reach (target 0.9 or more). Driven by a fixed action, it sees
  other views than the avoider's: the share is near, not exact.

Each pool is started and warmed (an episode on each worker) before its timing: a
benchmark's pool starts once and its workers keep their environments from episode to
episode (`lgmd_sim.core.jobs.kept`), so its throughput is that of its episodes; the
seconds the start-up took are reported beside.
"""

from __future__ import annotations

import os
import time

import numpy as np

from lgmd_sim.core.machine import cpu_name
from lgmd_sim.envs.zone import CRUISE, FALSE_ALARM_HORIZON
from scripts.speed import QUIET, format_table, met, on_warm_pool

#: The targets: the environment's share of the closed loop's time, the benchmark's two
#: workers against one, and against the environment alone on two.
SHARE_TARGET, SPEEDUP_TARGET, WORKERS_SHARE_TARGET = 0.9, 1.85, 0.9
#: Steps before timing starts (GL context, first frames, JIT caches).
WARMUP = 10
#: The fixed action of the environment alone: what the avoider does while cruising.
ACTION = np.array([0.6, 0.0], np.float32)


def _controlled(env, steps: int, controller) -> tuple[float, float]:
    """Seconds in the environment's steps and in the controller's actions, over `steps`
    steps driven by `controller` (resets outside the timing)."""
    obs, info = env.reset(seed=0)
    controller.reset()
    in_env = in_controller = 0.0
    for done in range(-WARMUP, steps):
        start = time.perf_counter()
        action = controller.act(obs, info)
        acted = time.perf_counter()
        obs, _, terminated, truncated, info = env.step(action)
        if done >= 0:
            in_controller += acted - start
            in_env += time.perf_counter() - acted
        if terminated or truncated:
            obs, info = env.reset()
            controller.reset()
    return in_env, in_controller


def measure_overhead(scenario: str, resolution: str, models: list[str], steps: int
                     ) -> list[dict]:
    import gymnasium as gym

    from lgmd_sim import controllers
    from lgmd_sim.envs.catalogue import scenario as scenario_of

    env = gym.make(scenario_of(scenario).env_id, resolution=resolution)
    rows = []
    try:
        for name in models:
            in_env, in_controller = _controlled(env, steps,
                                                controllers.make("reactive", model=name))
            rows.append({"what": f"ReactiveAvoid({name})",
                         "steps_per_s": steps / (in_env + in_controller),
                         "ratio": in_env / (in_env + in_controller)})
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
    """Frames per second of the closed-loop benchmark's episodes on one worker process and
    on two, and of the environment alone stepping as many frames per episode on one and
    on two: the limit the benchmark's workers would reach if the detector and the
    controller cost nothing. Each pool is started, and each of its workers has run one
    episode of its own (its imports, its environment and GL context, the models' compiled
    kernels), before the timing starts: a benchmark of a thousand episodes pays that once,
    and the seconds it took are reported beside."""
    from lgmd_sim.benchmark.episode import Cell, episode
    from lgmd_sim.core.jobs import Job
    from lgmd_sim.core.parallel import run_jobs

    cell = Cell(scenario, 1.0, "reactive", "feedback", "paper")

    def jobs_of(seeds: range) -> list[Job]:
        return [Job(cell.key(s), episode, {"cell": cell, "seed": s, "resolution": resolution,
                                           "cruise": CRUISE, "horizon": FALSE_ALARM_HORIZON})
                for s in seeds]

    def bare(jobs: list[Job], frames: dict[str, int]) -> list[Job]:
        return [Job(job.key, bare_episode, {
            "scenario": scenario, "jitter": cell.jitter, "resolution": resolution,
            "seed": job.kwargs["seed"], "frames": frames[job.key]}) for job in jobs]

    def timed(jobs: list[Job], warm: list[Job], workers: int
              ) -> tuple[float, float, dict[str, int]]:
        """Frames per second of `jobs` on a pool of `workers` warmed by `warm` (a job
        each), the seconds its start-up and warming took, and each job's frames."""
        frames: dict[str, int] = {}
        _, wall, startup = on_warm_pool(
            workers,
            lambda pool: run_jobs(warm[:workers], lambda job, record: None, QUIET, pool=pool),
            lambda pool: run_jobs(jobs, lambda job, record: frames.__setitem__(
                job.key, record["frames"]), QUIET, pool=pool))
        return sum(frames.values()) / wall, startup, frames

    jobs, warm = jobs_of(range(episodes)), jobs_of(range(episodes, episodes + 2))
    one, startup_one, frames = timed(jobs, warm, 1)
    two, startup_two, _ = timed(jobs, warm, 2)
    warm_frames = {job.key: 30 for job in warm}  # a short bare episode warms a worker
    bare_one, _, _ = timed(bare(jobs, frames), bare(warm, warm_frames), 1)
    bare_two, _, _ = timed(bare(jobs, frames), bare(warm, warm_frames), 2)
    return {"one": one, "two": two, "speedup": two / one, "bare_one": bare_one,
            "bare": bare_two, "bare_speedup": bare_two / bare_one, "share": two / bare_two,
            "startup_one": startup_one, "startup_two": startup_two}


def run(*, scenario: str = "RoughTerrainObstacles", resolution: str | list[int] = "rl",
        steps: int = 600, episodes: int = 24, markdown: bool = False) -> int:
    """Measure and print the closed-loop speed tables (Markdown with `markdown`)."""
    from lgmd_sim import models

    names = models.available()
    overhead = measure_overhead(scenario, resolution, names, steps)
    workers = measure_workers(scenario, resolution, episodes)
    print(f"# python -m scripts.speed closed-loop: {scenario} at {resolution}, {steps} "
          f"steps per run, {episodes} episodes per worker count; CPU: {cpu_name()}, "
          f"{os.cpu_count()} cores")
    print(format_table(
        ["closed loop", "steps/s", "share of the time in the environment's step",
         f"target {SHARE_TARGET}"],
        [[r["what"], f"{r['steps_per_s']:.0f}", f"{r['ratio']:.2f}",
          met(r["ratio"] >= SHARE_TARGET)] for r in overhead],
        markdown,
    ))
    print()
    print(format_table(
        ["frames/s", "1 worker", "2 workers", "speed-up", f"target {SPEEDUP_TARGET}x",
         "share of the environment's", f"target {WORKERS_SHARE_TARGET}"],
        [["closed-loop episodes, ReactiveAvoid(feedback), jitter 1", f"{workers['one']:.0f}",
          f"{workers['two']:.0f}", f"{workers['speedup']:.2f}x",
          met(workers["speedup"] >= SPEEDUP_TARGET), f"{workers['share']:.2f}",
          met(workers["share"] >= WORKERS_SHARE_TARGET)],
         ["the environment alone, as many frames per episode", f"{workers['bare_one']:.0f}",
          f"{workers['bare']:.0f}", f"{workers['bare_speedup']:.2f}x", "", "", ""]],
        markdown,
    ))
    print(f"\nStart-up before the timing (the pool's processes, their first episode): "
          f"{workers['startup_one']:.1f} s with 1 worker, {workers['startup_two']:.1f} s "
          "with 2.")
    return 0
