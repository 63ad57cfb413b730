"""Footage for the tests of detect and of the front ends (tests/detect/, tests/models/,
tests/cli/test_detect_command.py): an approach drawn by the stimuli, a scene seen by a
turning camera, written as a video or a folder of images."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from lgmd_sim import models
from lgmd_sim.models.stabilize import intrinsics, rotation_homography
from lgmd_sim.signals import stimuli

#: The clips' frame size (H, W).
SHAPE = (60, 80)
#: Every model a clip is run through.
MODELS = models.available()


def looming_clip() -> stimuli.Stimulus:
    """A square approaching over a texture, after three still frames."""
    return stimuli.approaching(SHAPE, start_distance=1.0, speed=2.0, still_frames=3,
                               look=stimuli.Look(background="texture"))


def write_video(path: Path, frames: np.ndarray, fourcc: str = "mp4v",
                fps: float = 30.0) -> Path:
    """Grey `frames` as a BGR video at `path`."""
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, SHAPE[::-1])
    assert w.isOpened()
    for f in frames:
        w.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
    w.release()
    return path


def write_folder(folder: Path, frames: np.ndarray) -> Path:
    """Grey `frames` as PNGs in `folder`, numbered without padding (natural order is not
    name order)."""
    folder.mkdir()
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"frame{i}.png"), f)
    return folder


def camera_turns(n: int, seed: int, degrees: float = 1.0) -> np.ndarray:
    """n seeded small camera rotations (rotation vectors, rad)."""
    return np.radians(degrees) * np.random.default_rng(seed).normal(size=(n, 3))


def turning_scene(n_frames: int, shape: tuple[int, int], seed: int = 0, fovy: float = 55.0
           ) -> tuple[np.ndarray, np.ndarray]:
    """A textured scene far away seen by a camera (of vertical field of view `fovy`,
    degrees) that turns a little each frame: uint8 frames (T, H, W) and each frame's turn
    since the previous one (T, 3; 0 first)."""
    h, w = shape
    rng = np.random.default_rng(seed)
    texture = cv2.GaussianBlur(rng.integers(0, 256, (3 * h, 3 * w)).astype(np.float32),
                               (0, 0), 2.0)
    texture = cv2.normalize(texture, None, 0, 255, cv2.NORM_MINMAX)
    k = intrinsics(fovy, h, w)
    centre = np.array([[1, 0, -w], [0, 1, -h], [0, 0, 1.0]])  # the texture's middle third
    turns = np.vstack([np.zeros(3), camera_turns(n_frames - 1, seed)])
    pose = np.eye(3)
    frames = []
    for r in turns:
        pose = rotation_homography(r, k) @ pose
        frames.append(cv2.warpPerspective(texture, pose @ centre, (w, h),
                                          flags=cv2.INTER_LINEAR))
    return np.clip(np.stack(frames) + 0.5, 0, 255).astype(np.uint8), turns
