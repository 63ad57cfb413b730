"""`lgmd-sim record`: a scenario's camera stream as a video file, with its collision frame.

The carrier drives straight at cruise speed (towards the goal where there is one; see
`lgmd_sim.controllers.Straight`); the frame of first collision is printed, ready for
``lgmd-sim detect VIDEO --collision-frame N``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from lgmd_sim.controllers import Straight, rollout
from lgmd_sim.envs.catalogue import scenario
from lgmd_sim.envs.wrappers.frames import check_frame_space
from lgmd_sim.signals.video import CODECS, video_writer

__all__ = ["Recording", "record"]


@dataclass(frozen=True)
class Recording:
    path: Path
    frames: int
    fps: float
    collision_frame: int | None


def record(name: str, path: str | Path, *, seed: int = 0, cruise: float = 1.0,
           progress: bool | None = False, **overrides: Any) -> Recording:
    """Record one episode of scenario `name` into the video `path` (see `CODECS`).

    Args:
        name: a catalogue scenario, e.g. "HandheldApproach".
        path: the video to write (.mkv / .avi lossless, .mp4 lossy).
        seed: the episode seed.
        cruise: forward action of the `Straight` controller.
        progress: show a progress bar on stderr (None: only on a terminal).
        **overrides: environment parameters (``jitter``, ``resolution``...).
    """
    from tqdm import tqdm

    path = Path(path)
    if path.suffix.lower() not in CODECS:  # before the episode runs
        raise ValueError(f"cannot write video '{path}': use a suffix among {', '.join(CODECS)}")
    env = gym.make(scenario(name).env_id, **overrides)
    try:
        check_frame_space(env.observation_space)  # frame='none': no video to write
        params = env.unwrapped.params
        fps = float(params.fps)
        collision, frames = None, 0
        with video_writer(path, fps, params.size) as write, tqdm(
                total=params.max_steps + 1, desc=path.name, unit="frame", file=sys.stderr,
                disable=None if progress is None else not progress, leave=False) as bar:
            for step in rollout(env, Straight(cruise=cruise), seed=seed):
                write(step.obs["frame"] if step.obs["frame"].shape[-1] == 3
                      else step.obs["frame"].repeat(3, axis=-1))
                if step.info["collision"] and collision is None:
                    collision = step.index
                frames += 1
                bar.update()
    finally:
        env.close()
    return Recording(path, frames, fps, collision)
