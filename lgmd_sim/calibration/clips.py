"""The calibration's clips: recorded once, then replayed to every candidate model.

A clip set is scenarios x jitter levels x seeds. Search and held-out sets use disjoint
seeds. Each clip is stored as ``<key>.npz``: its grey frames (uint8, what the models
see), and every per-frame number of the ground truth (time to collision, camera pose,
rotations...), so that front ends fed by the ground truth can replay it too.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.calibration.objective import ClipLabel
from lgmd_sim.fileio import atomic_output

__all__ = ["DEFAULT_GROUPS", "ClipSpec", "load_clip", "record_clip"]

#: The clips of the calibration, by kind: (scenario, jitter levels). The jitter clips are
#: the paper's jitter streams (ISI 0.69 to 0.76 at these levels), the stationary ones its
#: fixed-camera streams and the same scenes unshaken, the near misses its car passing by.
DEFAULT_GROUPS: dict[str, list[tuple[str, tuple[float, ...]]]] = {
    "jitter": [("HandheldApproach", (1.0, 1.5)), ("MutualApproach", (1.0, 1.5))],
    "stationary": [("StationaryApproach", (0.0,)), ("HandheldApproach", (0.0,)),
                   ("MutualApproach", (0.0,))],
    "near_miss": [("PassBy", (0.0, 1.0))],
}


@dataclass(frozen=True)
class ClipSpec:
    """One clip to record: a scenario episode driven straight ahead."""

    kind: str
    scenario: str
    jitter: float
    seed: int

    @property
    def key(self) -> str:
        return f"{self.scenario}-j{self.jitter:g}-s{self.seed}"


def record_clip(spec: ClipSpec, folder: str, resolution: Any) -> dict[str, Any]:
    """Record one clip into ``folder/<key>.npz`` (a job); return its label."""
    import cv2
    import gymnasium as gym

    from lgmd_sim.controllers import Straight, rollout
    from lgmd_sim.envs.catalogue import scenario

    env = gym.make(scenario(spec.scenario).env_id, jitter=spec.jitter, resolution=resolution)
    try:
        steps = list(rollout(env, Straight(), seed=spec.seed))
        fps = float(env.unwrapped.params.fps)
    finally:
        env.close()
    grey = np.stack([cv2.cvtColor(s.obs["frame"], cv2.COLOR_RGB2GRAY) for s in steps])
    truth = {}
    for name, value in steps[0].info.items():
        value = np.asarray(value)
        if value.dtype.kind in "fiub" and value.size <= 16:  # per-frame numbers only
            truth[name] = np.stack([np.asarray(s.info[name], np.float64) for s in steps])
    hit = int(steps[-1].info["first_collision_frame"])
    with atomic_output(Path(folder) / f"{spec.key}.npz") as tmp, open(tmp, "wb") as f:
        np.savez(f, frames=grey, fps=fps, **{f"truth_{k}": v for k, v in truth.items()})
    return {"kind": spec.kind, "frames": len(steps),
            "collision_frame": hit if hit >= 0 else None}


def load_clip(folder: str | Path, key: str) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
    """A recorded clip: grey frames (T, H, W), ground truth per frame, fps."""
    with np.load(Path(folder) / f"{key}.npz") as z:
        truth = {k[6:]: z[k] for k in z.files if k.startswith("truth_")}
        return z["frames"], truth, float(z["fps"])


def specs(groups: dict[str, list[tuple[str, tuple[float, ...]]]], seeds: Sequence[int]
          ) -> list[ClipSpec]:
    """Every clip of a set."""
    return [ClipSpec(kind, sc, j, s) for kind, entries in groups.items()
            for sc, levels in entries for j in levels for s in seeds]


def label(record: dict[str, Any]) -> ClipLabel:
    return ClipLabel(record["kind"], record["frames"], record["collision_frame"])
