"""`lgmd-sim speed envs`: environment steps per second against a bare render loop.

For every scenario of the catalogue, at 120 x 160 and at the paper's 270 x 480:

- a full environment step (physics substeps, rendering, proprioception and ground truth
  with SSIM), timed over ``--steps`` steps with resets outside the timing;
- a bare render loop of the same scene in the same process: the camera rendered into the
  same buffer, nothing else;
- the ratio of the two (target: a full step within 1.25x the bare render).

Then the same scenario in ``gym.make_vec(..., vectorization_mode="async")`` with one
and with two workers, each worker with its own GL context (target: two workers at 1.6x
or more the steps per second of one, on a 2-core machine).
"""

from __future__ import annotations

import os
import time

import numpy as np

from lgmd_sim.machine import cpu_name
from lgmd_sim.speed import format_table

RESOLUTIONS = ((120, 160), (270, 480))
#: Steps before timing starts (GL context, first frames, JIT caches).
WARMUP = 10
#: The timed action: forward at half speed, a slight turn so the view changes.
ACTION = np.array([0.5, 0.1], np.float32)


def _env_steps_per_s(env, steps: int) -> float:
    env.reset(seed=0)
    for _ in range(WARMUP):
        env.step(ACTION)
    elapsed, done_steps = 0.0, 0
    while done_steps < steps:
        start = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(ACTION)
        elapsed += time.perf_counter() - start
        done_steps += 1
        if terminated or truncated:
            env.reset()
    return done_steps / elapsed


def _render_per_s(world, steps: int) -> float:
    buf = np.empty_like(world.rgb)
    for _ in range(WARMUP):
        world.render_camera(buf)
    start = time.perf_counter()
    for _ in range(steps):
        world.render_camera(buf)
    return steps / (time.perf_counter() - start)


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
                step_rate = _env_steps_per_s(env, steps)
                render_rate = _render_per_s(env.unwrapped.world, steps)
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

    print(f"# lgmd-sim speed envs: {steps} steps per run; CPU: {cpu_name()}, "
          f"{os.cpu_count()} cores; MUJOCO_GL={BACKEND}")
    print(format_table(
        ["scenario", "size", "env steps/s", "bare renders/s", "step / render time"],
        [[r["scenario"], r["size"], f"{r['steps_per_s']:.0f}", f"{r['render_per_s']:.0f}",
          f"{r['ratio']:.2f}x"] for r in single],
        markdown,
    ))
    print()
    print(format_table(
        ["scenario (120x160)", "1 async worker steps/s", "2 async workers steps/s", "speed-up"],
        [[r["scenario"], f"{r['one']:.0f}", f"{r['two']:.0f}", f"{r['speedup']:.2f}x"]
         for r in scaling],
        markdown,
    ))
    return 0
