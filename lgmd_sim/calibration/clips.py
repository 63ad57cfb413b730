"""The calibration's clips: recorded once, then replayed to every candidate model.

A clip set is scenarios x jitter levels x seeds. Search and held-out sets use disjoint
seeds. A scenario is an environment's (driven straight ahead) or a synthetic stimulus of
`STIMULI` (its shake: `lgmd_sim.signals.stimuli.jittered` at the jitter level). A task may add a
camera's noise (`lgmd_sim.signals.noise`) to every frame, seeded by the clip's seed. Each clip is
stored as ``<key>.npz``: its grey frames (uint8, what the models see), every per-frame
number of the ground truth (time to collision, camera pose, rotations...), so that front
ends fed by the ground truth can replay it too, and per front end the motions the model
would compute (`clip_motions`).
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.calibration.objective import WALKER, ClipLabel
from lgmd_sim.controllers import Straight
from lgmd_sim.core.fileio import atomic_output
from lgmd_sim.signals import noise as noise_mod
from lgmd_sim.signals import stimuli

__all__ = ["DEFAULT_GROUPS", "FRONT_ENDS", "LOOKAHEAD", "ROBOT_GROUPS", "STIMULI",
           "VIDEO_FOVY", "VIDEO_FOVY_RANGE", "VIDEO_GROUPS", "VIDEO_LOOKS", "ClipSpec",
           "HoldLine", "Looks", "clip_motions", "label", "load_clip", "load_gains", "load_truth",
           "record_clip", "specs", "stimulus_clip"]

#: The front ends a calibrated detector may have (see `lgmd_sim.models.stabilize`): the
#: rotation fitted from the frames, or the IMU's, and the fitted rotation with the
#: brightness gain (the video task's: a video has neither pose nor IMU).
FRONT_ENDS = ("image", "imu", "image+gain")

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


#: The video task's clips (`lgmd_sim.calibration.tasks`, "video"): the walker's kinds, with
#: synthetic looming among the collisions, and a fourth kind that must stay silent:
#: stimuli that move, flicker or drift without looming (`STIMULI`).
VIDEO_GROUPS: dict[str, list[tuple[str, tuple[float, ...]]]] = {
    "jitter": [("HandheldApproach", (1.0, 1.5)), ("MutualApproach", (1.0,)),
               ("Looming", (1.0, 2.0))],
    "stationary": [("StationaryApproach", (0.0,)), ("Looming", (0.0,))],
    "near_miss": [("PassBy", (0.0, 1.0))],
    "non_looming": [("Receding", (0.0, 1.0)), ("Translating", (0.0, 1.0)),
                    ("Rotating", (0.0, 1.0)), ("Grating", (0.0, 1.0)),
                    ("Flicker", (0.0, 1.0))],
}


@dataclass(frozen=True)
class Looks:
    """A family of looks clips are recorded in: a camera's noise on every frame
    (`lgmd_sim.signals.noise`, seeded by the clip's seed), the scenes' light (environment
    parameters of the scenario clips) and the synthetic stimuli's background."""

    noise: str = ""
    scene: Mapping[str, Any] = field(default_factory=dict)
    background: str = "texture"


#: The video task's looks: "" the calibration's (search and held-out seeds), a real
#: unstabilised camera adding white shake at video rate, motion blur, auto-exposure,
#: sensor noise and compression to each clip's shake (level 1 of each, JPEG quality 70, a
#: web video's), on the scenes' default light and textured stimuli; "transfer" the
#: held-out check of a domain the calibration never saw: a worse camera (twice the shake,
#: blur, exposure and sensor noise, JPEG 40), a low sun with passing shade and flicker,
#: stimuli on plain grounds.
VIDEO_LOOKS: dict[str, Looks] = {
    "": Looks("shake:0.5,blur:1,exposure:1,sensor:1,jpeg:70"),
    "transfer": Looks("shake:1,blur:2,exposure:2,sensor:2,jpeg:40",
                      {"sun_elevation": 15.0, "shade": 0.6, "flicker": 0.15}, "uniform"),
}
#: The vertical field of view (degrees) the video presets' front end assumes, the middle
#: of real cameras' `VIDEO_FOVY_RANGE`, over which the video task's scenario clips draw
#: their camera's: the calibration sees the fit made with the wrong focal length.
VIDEO_FOVY = 60.0
VIDEO_FOVY_RANGE = (40.0, 90.0)


def _look(rng: np.random.Generator, seed: int, background: str) -> stimuli.Look:
    return stimuli.Look(polarity=str(rng.choice(["dark", "light"])),
                        form=str(rng.choice(["square", "disc"])),
                        contrast=float(rng.uniform(0.3, 0.8)), background=background,
                        seed=seed)


#: Synthetic stimuli as clip scenarios (`lgmd_sim.signals.stimuli`), each drawn per clip from its
#: seed (the object's polarity, form and contrast on the looks' background; speeds,
#: periods and frequencies): a looming object (to collision), and five that do not loom:
#: an object receding, crossing the view or turning, a drifting grating, the whole field
#: dimming and lightening. Each takes the frame shape, the clip's generator, seed and background.
STIMULI: dict[str, Callable[[tuple[int, int], np.random.Generator, int, str],
                            stimuli.Stimulus]] = {
    "Looming": lambda shape, rng, seed, bg: stimuli.approaching(
        shape, speed=float(rng.uniform(1.5, 3.0)), look=_look(rng, seed, bg)),
    "Receding": lambda shape, rng, seed, bg: stimuli.receding(
        shape, speed=float(rng.uniform(1.0, 3.0)), look=_look(rng, seed, bg)),
    "Translating": lambda shape, rng, seed, bg: stimuli.translating(
        shape, speed=float(rng.uniform(0.5, 2.0)), look=_look(rng, seed, bg)),
    "Rotating": lambda shape, rng, seed, bg: stimuli.rotating(
        shape, rate=float(rng.uniform(60, 360)), distance=float(rng.uniform(0.5, 1.5)),
        n_frames=90, look=_look(rng, seed, bg)),
    "Grating": lambda shape, rng, seed, bg: stimuli.grating(
        shape, period=float(rng.uniform(10, 40)), speed=float(rng.uniform(20, 120)),
        orientation=float(rng.uniform(0, 360)), contrast=float(rng.uniform(0.2, 0.8)),
        n_frames=90),
    "Flicker": lambda shape, rng, seed, bg: stimuli.flicker(
        shape, frequency=float(rng.uniform(0.5, 3.0)), depth=float(rng.uniform(0.1, 0.5)),
        background=bg, n_frames=90, seed=seed),
}


def stimulus_clip(name: str, jitter: float, seed: int, resolution: Any,
                  background: str = "texture") -> stimuli.Stimulus:
    """Stimulus `name` of `STIMULI` drawn from `seed` (its own generator: the same clip
    whatever else a set holds) at the frame size of `resolution` on `background`, shaken
    at `jitter` (`lgmd_sim.signals.stimuli.jittered`, seeded by `seed`)."""
    from lgmd_sim.world.params import frame_size

    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    return stimuli.jittered(STIMULI[name](frame_size(resolution), rng, seed, background),
                            jitter, seed)


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
    """One clip to record: a scenario episode driven straight ahead, or a stimulus, in
    the task's looks of that name ("": its own)."""

    kind: str
    scenario: str
    jitter: float
    seed: int
    looks: str = ""

    @property
    def key(self) -> str:
        return f"{self.scenario}-j{self.jitter:g}-s{self.seed}" + (
            f"-{self.looks}" if self.looks else "")


def record_clip(spec: ClipSpec, folder: str, resolution: Any, cruise: float | None = None,
                fronts: Sequence[str] = ("image", "imu"), looks: Looks = Looks(),
                fovy: float | None = None) -> dict[str, Any]:
    """Record one clip into ``folder/<key>.npz`` (a job); return its label. An
    environment's carrier is driven by `Straight` (the walker's clips), or with `cruise`
    by `HoldLine` at that forward action (the robot's); a stimulus of `STIMULI` is drawn.
    `looks` gives the scene's light, the stimulus's background and the noise that
    corrupts every frame (seeded by the clip's seed). The motions
    of each front end of `fronts` are kept, fitted with the camera's field of view, or
    with `fovy` (degrees) where given: the one a preset's front end will assume; a clip
    with `fovy` draws its camera's from `VIDEO_FOVY_RANGE`."""
    import cv2

    if spec.scenario in STIMULI:
        clip = stimulus_clip(spec.scenario, spec.jitter, spec.seed, resolution,
                             looks.background)
        frames, truth, camera_fovy = list(clip.frames), {}, None
        hit, fps = clip.collision_frame, clip.fps
    else:
        frames, truth, camera_fovy, hit, fps = _scenario_clip(spec, resolution, cruise,
                                                              fovy is not None, looks.scene)
    noises = noise_mod.parse(looks.noise)
    frames = [noise_mod.apply(f, noises, spec.seed, t) for t, f in enumerate(frames)]
    grey = np.stack([f if f.ndim == 2 else cv2.cvtColor(f, cv2.COLOR_RGB2GRAY)
                     for f in frames])
    motions = {}
    for front in fronts:
        hs, grids = clip_motions(grey, truth, front, fovy or camera_fovy)
        motions[f"motion_{front}"] = hs
        if grids is not None:
            motions[f"gains_{front}"] = grids
    with atomic_output(Path(folder) / f"{spec.key}.npz") as tmp, open(tmp, "wb") as f:
        np.savez(f, frames=grey, fps=fps, camera_fovy=np.nan if camera_fovy is None
                 else camera_fovy, **motions, **{f"truth_{k}": v for k, v in truth.items()})
    return {"kind": spec.kind, "frames": len(grey),
            "collision_frame": None if hit is None or hit < 0 else int(hit)}


def _scenario_clip(spec: ClipSpec, resolution: Any, cruise: float | None, any_fovy: bool,
                   scene: Mapping[str, Any]
                   ) -> tuple[list[np.ndarray], dict[str, np.ndarray], float, int, float]:
    """An environment's clip: its RGB frames, per-frame ground truth, camera's vertical
    field of view, first collision frame (-1 for none) and frames per second."""
    from lgmd_sim.controllers import rollout
    from lgmd_sim.envs.reuse import episode_env
    from lgmd_sim.envs.wrappers.frames import check_frame_space

    camera = {}
    if any_fovy:  # drawn from the seed alone: the same clip whatever else the set holds
        rng = np.random.default_rng([spec.seed, zlib.crc32(b"fovy")])
        camera = {"fovy": float(rng.uniform(*VIDEO_FOVY_RANGE))}
    with episode_env(spec.scenario, jitter=spec.jitter, resolution=resolution, **camera,
                     **scene) as env:
        check_frame_space(env.observation_space)
        driver = Straight() if cruise is None else HoldLine(cruise=cruise)
        steps = list(rollout(env, driver, seed=spec.seed))
        fovy, fps = float(env.unwrapped.params.fovy), float(env.unwrapped.params.fps)
    truth = {}
    for name, value in steps[0].info.items():
        value = np.asarray(value)
        if value.dtype.kind in "fiub" and value.size <= 16:  # per-frame numbers only
            truth[name] = np.stack([np.asarray(s.info[name], np.float64) for s in steps])
    return ([s.obs["frame"] for s in steps], truth, fovy,
            int(steps[-1].info["first_collision_frame"]), fps)


def clip_motions(grey: np.ndarray, truth: dict[str, np.ndarray], front: str, fovy: float
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """Each frame's homography (T, 3, 3) from the front end `front` ("image": fitted from
    the frames; "imu": from the IMU's rotations; "image+gain": fitted, with the brightness
    gain), exactly as a model with that front end computes it, and with a gain its
    `lgmd_sim.models.stabilize.gain_grid` per frame (T, rows, cols), else None: a
    candidate then runs the plain model with ``motion=`` and gets the potentials of the
    stabilized one, without fitting the same clip again."""
    from types import SimpleNamespace

    from lgmd_sim.models.stabilize import FrontEnd

    stabilize, _, gain = front.partition("+")
    rotations = truth.get(f"{stabilize}_rotation")
    if stabilize == "imu" and rotations is None:
        raise ValueError("front end imu: the clip has no IMU (a synthetic stimulus?)")
    front_end = FrontEnd(SimpleNamespace(stabilize=stabilize, fovy=fovy, gain=bool(gain)), 1)
    hs, grids = [], []
    for t, g in enumerate(grey):
        hs.append(front_end.motion(g[None], None if rotations is None else rotations[t])
                  .homography[0])
        if gain:
            grids.append(front_end.gain_grids[0].copy())
    return np.stack(hs), np.stack(grids) if gain else None


def load_clip(folder: str | Path, key: str, front: str | None = None
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """A recorded clip: its grey frames (T, H, W), and with `front` its homographies."""
    with np.load(Path(folder) / f"{key}.npz") as z:
        return z["frames"], (z[f"motion_{front}"] if front else None)


def load_gains(folder: str | Path, key: str, front: str) -> np.ndarray | None:
    """A recorded clip's gain grids of front end `front` (T, rows, cols), None for a front
    end without a gain."""
    with np.load(Path(folder) / f"{key}.npz") as z:
        return z[f"gains_{front}"] if f"gains_{front}" in z.files else None


def load_truth(folder: str | Path, key: str, names: Sequence[str]) -> dict[str, np.ndarray]:
    """Per-frame ground truth of a recorded clip (``info`` names), each (T, ...)."""
    with np.load(Path(folder) / f"{key}.npz") as z:
        return {name: z[f"truth_{name}"] for name in names}


def specs(groups: Mapping[str, list[tuple[str, tuple[float, ...]]]], seeds: Sequence[int],
          looks: str = "") -> list[ClipSpec]:
    """Every clip of a set, in the looks of that name."""
    return [ClipSpec(kind, sc, j, s, looks) for kind, entries in groups.items()
            for sc, levels in entries for j in levels for s in seeds]


def label(record: dict[str, Any]) -> ClipLabel:
    """A walker clip's label, from its record."""
    return WALKER.label(record, {})
