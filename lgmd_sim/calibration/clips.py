"""The calibration's clips: recorded once, then replayed to every candidate model.

A clip set is scenarios x jitter levels x seeds. Search and held-out sets use disjoint
seeds. Each clip is stored as ``<key>.npz``: its grey frames (uint8, what the models
see), and every per-frame number of the ground truth (time to collision, camera pose,
rotations...), so that front ends fed by the ground truth can replay it too.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.calibration.objective import WALKER, ClipLabel
from lgmd_sim.controllers import Straight
from lgmd_sim.fileio import atomic_output

__all__ = ["DEFAULT_GROUPS", "FRONT_ENDS", "LOOKAHEAD", "ROBOT_GROUPS", "ClipSpec", "HoldLine",
           "clip_motions", "label", "load_clip", "load_truth", "record_clip", "specs"]

#: The front ends the calibration also tunes every detector with (see
#: `lgmd_sim.models.stabilize`): the rotation fitted from the frames, or the IMU's.
FRONT_ENDS = ("image", "imu")

#: The clips of the calibration, by kind: (scenario, jitter levels). The jitter clips are
#: the paper's jitter streams (ISI 0.69 to 0.76 at these levels), the stationary ones its
#: fixed-camera streams and the same scenes unshaken, the near misses its car passing by.
DEFAULT_GROUPS: dict[str, list[tuple[str, tuple[float, ...]]]] = {
    "jitter": [("HandheldApproach", (1.0, 1.5)), ("MutualApproach", (1.0, 1.5))],
    "stationary": [("StationaryApproach", (0.0,)), ("HandheldApproach", (0.0,)),
                   ("MutualApproach", (0.0,))],
    "near_miss": [("PassBy", (0.0, 1.0))],
}
#: The robot's clips (`lgmd_sim.calibration.robot`), by kind: driving at an obstacle, and
#: driving where none is in its way, over ground as rough as the closed-loop benchmark's.
ROBOT_GROUPS: dict[str, list[tuple[str, tuple[float, ...]]]] = {
    "approach": [("RobotApproach", (0.0, 1.0, 2.0)), ("RobotWallAhead", (0.0, 1.0, 2.0))],
    "clear": [("RobotOpenGround", (0.0, 1.0, 2.0)), ("RobotPassBy", (0.0, 1.0, 2.0))],
}


#: How far ahead on its line the robot's clips steer for (m).
LOOKAHEAD = 2.0


class HoldLine(Straight):
    """`Straight` steering for a point `LOOKAHEAD` ahead on the line y = 0, the line the
    robot's scenarios place their obstacles by: the rough ground turns the robot as it
    settles at the start (up to about 30 degrees at jitter 2) and as it drives, so that
    without it an approach would miss its obstacle and a pass-by meet one."""

    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        _x, y = info["carrier_pos"][:2]
        w, qx, qy, qz = info["carrier_quat"]
        yaw = math.atan2(2 * (w * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        bearing = math.remainder(math.atan2(-y, LOOKAHEAD) - yaw, math.tau)
        return super().act(obs, {**info, "goal_bearing": bearing})


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


def record_clip(spec: ClipSpec, folder: str, resolution: Any, cruise: float | None = None
                ) -> dict[str, Any]:
    """Record one clip into ``folder/<key>.npz`` (a job); return its label. The carrier is
    driven by `Straight` (the walker's clips), or with `cruise` by `HoldLine` at that
    forward action (the robot's)."""
    import cv2
    import gymnasium as gym

    from lgmd_sim.controllers import rollout
    from lgmd_sim.envs.catalogue import scenario
    from lgmd_sim.envs.wrappers.frames import check_frame_space

    env = gym.make(scenario(spec.scenario).env_id, jitter=spec.jitter, resolution=resolution)
    try:
        check_frame_space(env.observation_space)
        driver = Straight() if cruise is None else HoldLine(cruise=cruise)
        steps = list(rollout(env, driver, seed=spec.seed))
        fps, fovy = float(env.unwrapped.params.fps), float(env.unwrapped.params.fovy)
    finally:
        env.close()
    grey = np.stack([cv2.cvtColor(s.obs["frame"], cv2.COLOR_RGB2GRAY) for s in steps])
    truth = {}
    for name, value in steps[0].info.items():
        value = np.asarray(value)
        if value.dtype.kind in "fiub" and value.size <= 16:  # per-frame numbers only
            truth[name] = np.stack([np.asarray(s.info[name], np.float64) for s in steps])
    hit = int(steps[-1].info["first_collision_frame"])
    motions = {f"motion_{front}": clip_motions(grey, truth, front, fovy)
               for front in FRONT_ENDS}
    with atomic_output(Path(folder) / f"{spec.key}.npz") as tmp, open(tmp, "wb") as f:
        np.savez(f, frames=grey, fps=fps, **motions,
                 **{f"truth_{k}": v for k, v in truth.items()})
    return {"kind": spec.kind, "frames": len(steps),
            "collision_frame": hit if hit >= 0 else None}


def clip_motions(grey: np.ndarray, truth: dict[str, np.ndarray], front: str, fovy: float
                 ) -> np.ndarray:
    """Each frame's homography (T, 3, 3) from the front end `front` ("image": fitted from
    the frames; "imu": from the IMU's rotations), exactly as a model with that front end
    computes it: a candidate then runs the plain model with ``motion=`` and gets the
    potentials of the stabilized one, without fitting the same clip again."""
    from types import SimpleNamespace

    from lgmd_sim.models.stabilize import FrontEnd

    front_end = FrontEnd(SimpleNamespace(stabilize=front, fovy=fovy, gain=False), 1)
    rotations = truth.get(f"{front}_rotation")
    return np.stack([front_end.motion(g[None], None if rotations is None else rotations[t])
                     .homography[0] for t, g in enumerate(grey)])


def load_clip(folder: str | Path, key: str, front: str | None = None
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """A recorded clip: its grey frames (T, H, W), and with `front` its homographies."""
    with np.load(Path(folder) / f"{key}.npz") as z:
        return z["frames"], (z[f"motion_{front}"] if front else None)


def load_truth(folder: str | Path, key: str, names: Sequence[str]) -> dict[str, np.ndarray]:
    """Per-frame ground truth of a recorded clip (``info`` names), each (T, ...)."""
    with np.load(Path(folder) / f"{key}.npz") as z:
        return {name: z[f"truth_{name}"] for name in names}


def specs(groups: dict[str, list[tuple[str, tuple[float, ...]]]], seeds: Sequence[int]
          ) -> list[ClipSpec]:
    """Every clip of a set."""
    return [ClipSpec(kind, sc, j, s) for kind, entries in groups.items()
            for sc, levels in entries for j in levels for s in seeds]


def label(record: dict[str, Any]) -> ClipLabel:
    """A walker clip's label, from its record."""
    return WALKER.label(record, {})
