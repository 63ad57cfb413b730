"""`python -m scripts.speed envs`: environment steps per second against bare renders of its views.

For every scenario of the catalogue, at 120 x 160 and at the paper's 270 x 480:

- a full environment step (physics substeps, rendering, proprioception and ground truth;
  no SSIM, which only its consumers ask for), timed over ``--steps`` steps with resets
  outside the timing;
- a bare render of the same views: after each step, the state it left rendered again into
  one buffer, nothing else, timed apart. Not a loop over one state: a view's cost
  depends on what it shows (the terrain's tiles in view, the obstacles), so one state's
  render is no baseline for an episode's;
- the ratio of the two (target: a full step within 1.15x the bare render, `STEP_TARGET`).

Then the same scenario in ``gym.make_vec(..., vectorization_mode="async")`` with one
and with two workers, each worker with its own GL context (target: two workers at 1.6x
or more the steps per second of one, on a 2-core machine).
"""

from __future__ import annotations

import os
import time

import numpy as np

from lgmd_sim.core.machine import cpu_name
from scripts.speed import format_table, met

RESOLUTIONS = ((120, 160), (270, 480))
#: The targets: a full step within this many bare renders of the same views, and two
#: async workers at this many times one's steps per second.
STEP_TARGET, WORKERS_TARGET = 1.15, 1.6
#: Steps before timing starts (GL context, first frames, JIT caches).
WARMUP = 10
#: The timed action: forward at half speed, a slight turn so the view changes.
ACTION = np.array([0.5, 0.1], np.float32)


def _steps_and_renders_per_s(env, steps: int) -> tuple[float, float]:
    """Full steps per second, and bare renders per second of the states they left."""
    world = env.unwrapped.world
    env.reset(seed=0)
    for _ in range(WARMUP):
        env.step(ACTION)
    buf = np.empty_like(world.rgb)
    in_steps = in_renders = 0.0
    for _ in range(steps):
        start = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(ACTION)
        stepped = time.perf_counter()
        world.render_camera(buf)
        in_renders += time.perf_counter() - stepped
        in_steps += stepped - start
        if terminated or truncated:
            env.reset()
    return steps / in_steps, steps / in_renders


def _vector_steps_per_s(env_id: str, workers: int, steps: int) -> float:
    import gymnasium as gym

    envs = gym.make_vec(env_id, num_envs=workers, vectorization_mode="async",
                        resolution=list(RESOLUTIONS[0]))
    try:
        envs.reset(seed=0)
        actions = np.tile(ACTION, (workers, 1))
        for _ in range(WARMUP):
            envs.step(actions)
        start = time.perf_counter()
        for _ in range(steps):
            envs.step(actions)  # finished sub-environments reset themselves
        return steps * workers / (time.perf_counter() - start)
    finally:
        envs.close()


def measure(steps: int) -> tuple[list[dict], list[dict]]:
    """Per-scenario step and render rates, and async worker scaling."""
    import gymnasium as gym

    from lgmd_sim.envs.catalogue import scenarios

    single, scaling = [], []
    for name, sc in scenarios().items():
        for h, w in RESOLUTIONS:
            env = gym.make(sc.env_id, resolution=[h, w])
            try:
                step_rate, render_rate = _steps_and_renders_per_s(env, steps)
            finally:
                env.close()
            single.append({"scenario": name, "size": f"{h}x{w}", "steps_per_s": step_rate,
                           "render_per_s": render_rate, "ratio": render_rate / step_rate})
        one = _vector_steps_per_s(sc.env_id, 1, steps)
        two = _vector_steps_per_s(sc.env_id, 2, steps)
        scaling.append({"scenario": name, "one": one, "two": two, "speedup": two / one})
    return single, scaling


def run(*, steps: int = 200, markdown: bool = False) -> int:
    """Measure and print the environment speed tables (Markdown with `markdown`)."""
    single, scaling = measure(steps)
    from lgmd_sim.world.gl import BACKEND  # chosen by lgmd_sim.world when it loaded

    print(f"# python -m scripts.speed envs: {steps} steps per run; CPU: {cpu_name()}, "
          f"{os.cpu_count()} cores; MUJOCO_GL={BACKEND}")
    print(format_table(
        ["scenario", "size", "env steps/s", "bare renders/s", "step / render time",
         f"target {STEP_TARGET}x"],
        [[r["scenario"], r["size"], f"{r['steps_per_s']:.0f}", f"{r['render_per_s']:.0f}",
          f"{r['ratio']:.2f}x", met(r["ratio"] <= STEP_TARGET)] for r in single],
        markdown,
    ))
    print()
    print(format_table(
        ["scenario (120x160)", "1 async worker steps/s", "2 async workers steps/s", "speed-up",
         f"target {WORKERS_TARGET}x"],
        [[r["scenario"], f"{r['one']:.0f}", f"{r['two']:.0f}", f"{r['speedup']:.2f}x",
          met(r["speedup"] >= WORKERS_TARGET)] for r in scaling],
        markdown,
    ))
    return 0
