"""`python -m scripts.speed dataset`: dataset generation against the environment alone, and disk
per frame.

For each scenario, in one run, with the same workers, episodes, seeds and frame size:

- the environment alone: the episodes driven by the same controller as jobs of
  `lgmd_sim.core.parallel.run_jobs`, frames thrown away;
- ``dataset generate`` of the same episodes into a temporary folder (everything: frames
  encoded, labels, files written, the manifest and contact sheet);
- frames per second of both and their ratio (`TARGET`: 0.9 or more with 2 workers), the
  best of ``--repeat`` interleaved rounds of each, and the same ratio in CPU time (CPU
  seconds per frame of this process and its workers), which other jobs on a shared
  machine disturb far less. Each is timed on a pool started and warmed before (the same
  episodes once, as a run's later episodes find their workers: imports done,
  environments built), as a long run pays its start-up once; the start-up is printed
  apart;
- disk per frame of the stored frames, against the same frames as PNG files (OpenCV's
  default compression) and raw RGB, and of the labels.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import cv2

from lgmd_sim.core.jobs import Job
from lgmd_sim.core.machine import cpu_name
from lgmd_sim.core.parallel import run_jobs
from lgmd_sim.core.pool import Pool
from lgmd_sim.data.generate import GenerateConfig, generate
from scripts.speed import QUIET, format_table, met, on_warm_pool

#: The target: dataset generation at this share of the environment's frames per second.
TARGET = 0.9


def drive(scenario: str, overrides: dict[str, Any], seed: int, controller: str) -> int:
    """One episode with nothing stored: the environment's own cost. Returns its frames."""
    from lgmd_sim import controllers
    from lgmd_sim.envs.reuse import episode_env

    with episode_env(scenario, ssim=True, **overrides) as env:  # as the dataset's
        return sum(1 for _ in controllers.rollout(env, controllers.make(controller), seed=seed))


def _worker_cpu() -> tuple[int, float]:
    """A worker's process id and CPU seconds (all its threads) so far (a job)."""
    return os.getpid(), time.process_time()


def _pool_cpu(pool: Pool) -> float:
    """CPU seconds of the pool's workers so far: a job to each (an idle pool hands one to
    every worker)."""
    cpu: dict[int, float] = {}
    run_jobs([Job(f"cpu {i}", _worker_cpu) for i in range(pool.size)],
             lambda job, r: cpu.__setitem__(*r), QUIET, pool=pool)
    if len(cpu) != pool.size:
        raise RuntimeError("speed dataset: a worker took two CPU-time jobs")
    return sum(cpu.values())


def _timed(run: Callable[[Pool], int], workers: int) -> tuple[int, float, float, float]:
    """`run` on a pool of `workers` warmed by running it once: its frames, wall and CPU
    seconds (this process and the workers), and the seconds the pool's start and the
    warming took."""
    def counted(pool: Pool) -> tuple[int, float, float]:
        cpu = _pool_cpu(pool) + time.process_time()
        begin = time.perf_counter()
        frames = run(pool)
        wall = time.perf_counter() - begin
        return frames, wall, _pool_cpu(pool) + time.process_time() - cpu

    (frames, wall, cpu), _, warm = on_warm_pool(workers, run, counted)
    return frames, wall, cpu, warm


def _env_run(config: GenerateConfig, pool: Pool) -> int:
    """The environment alone: its frames."""
    frames = []
    jobs = [Job(s.key, drive, {"scenario": s.scenario, "overrides": dict(s.overrides),
                               "seed": s.seed, "controller": s.controller})
            for s in config.specs()]
    run_jobs(jobs, lambda job, n: frames.append(n), QUIET, pool=pool)
    return sum(frames)


def _generate_run(config: GenerateConfig, out: Path, pool: Pool) -> int:
    """Dataset generation into a new folder `out` (removed first): its frames."""
    shutil.rmtree(out, ignore_errors=True)
    return generate(config, out, QUIET, pool=pool).frames


def _disk(root: Path, video: str) -> dict[str, float]:
    """Bytes per frame: stored frames, the same frames as PNG, raw RGB, labels."""
    from lgmd_sim.data import layout
    from lgmd_sim.data.load import open_dataset

    ds = open_dataset(root)
    frames = ds.info["total_frames"]
    stored = sum((root / layout.video_path(ep.index, video)).stat().st_size for ep in ds)
    labels = sum(ep.data_path.stat().st_size for ep in ds)
    png, raw = 0, 0
    for ep in ds:
        for rgb in ep.iter_frames():
            _ok, buf = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
            png += buf.size
            raw += rgb.nbytes
    return {"stored": stored / frames, "png": png / frames, "raw": raw / frames,
            "labels": labels / frames}


def measure(scenarios: list[str], episodes: int, resolution: Any, workers: int, video: str,
            repeat: int) -> list[dict[str, Any]]:
    """Per scenario: frames/s (the best of `repeat` interleaved rounds) and CPU seconds per
    frame (the least) of the environment alone and of generation, and the start-up of
    their pools (the longest); disk per frame."""
    rows = []
    for name in scenarios:
        config = GenerateConfig((name,), (1.0,), episodes, resolution, video=video)
        best = {"env": (0.0, math.inf, 0.0), "gen": (0.0, math.inf, 0.0)}
        with tempfile.TemporaryDirectory(prefix="lgmd-sim-speed-") as tmp:
            out = Path(tmp) / "ds"
            for _ in range(repeat):  # interleaved, so that a busy spell hits both alike
                for what, run in (("env", partial(_env_run, config)),
                                  ("gen", partial(_generate_run, config, out))):
                    frames, wall, cpu, warm = _timed(run, workers)
                    fps, cpf, start = best[what]
                    best[what] = (max(fps, frames / wall), min(cpf, cpu / frames),
                                  max(start, warm))
            disk = _disk(out, video)
        (env_fps, env_cpf, env_start), (gen_fps, gen_cpf, gen_start) = best.values()
        rows.append({"scenario": name, "frames": frames, "env_fps": env_fps,
                     "gen_fps": gen_fps, "ratio": gen_fps / env_fps,
                     "cpu_ratio": env_cpf / gen_cpf, "env_start": env_start,
                     "gen_start": gen_start, **disk})
    return rows


def run(*, scenarios: str = "all", episodes: int = 6, resolution: str | list[int] = "paper",
        workers: int = 2, repeat: int = 2, video: str = "huffyuv",
        markdown: bool = False) -> int:
    """Measure and print the dataset-generation speed table (Markdown with `markdown`)."""
    from lgmd_sim.controllers import options
    from lgmd_sim.data.layout import VIDEO_FORMATS
    from lgmd_sim.envs import catalogue
    from lgmd_sim.world.params import frame_size

    names = options.names(scenarios, list(catalogue.scenarios()), "scenario(s)")
    h, w = frame_size(resolution)
    rows = measure(names, episodes, resolution, workers, video, repeat)
    codec = VIDEO_FORMATS[video].codec
    print(f"# python -m scripts.speed dataset: {h}x{w}, jitter 1, {episodes} episodes per "
          f"scenario, {workers} workers, best of {repeat} rounds, frames "
          f"{video}; CPU: "
          f"{cpu_name()}, {os.cpu_count()} cores")
    print(format_table(
        ["scenario", "frames", "env frames/s", "dataset frames/s", "dataset / env",
         f"target {TARGET}", "same, in CPU time", f"{codec} KB/frame", "PNG KB/frame",
         "raw KB/frame", "labels KB/frame"],
        [[r["scenario"], str(r["frames"]), f"{r['env_fps']:.0f}", f"{r['gen_fps']:.0f}",
          f"{r['ratio']:.2f}", met(r["ratio"] >= TARGET), f"{r['cpu_ratio']:.2f}",
          f"{r['stored'] / 1000:.1f}", f"{r['png'] / 1000:.1f}", f"{r['raw'] / 1000:.1f}",
          f"{r['labels'] / 1000:.2f}"] for r in rows],
        markdown,
    ))
    print(f"\nStart-up before each timing (the pool's processes, then the same episodes once): "
          f"up to {max(r['env_start'] for r in rows):.1f} s for the environment alone, "
          f"{max(r['gen_start'] for r in rows):.1f} s for generation.")
    return 0
