"""`lgmd-sim demo`: the robot drives straight at an obstacle over rough ground.

One episode of RoughTerrainObstacles at the paper's 270 x 480: a proportional heading
controller keeps the robot on the line to the goal, with an obstacle standing in the way,
while an LGMD model (the feedback LGMD by default) watches the camera. Writes

- ``demo.mp4``: the camera view beside the model's S layer, and below them the membrane
  potential so far, with the threshold and the collision frame;
- ``demo.png``: a summary: frames at key moments, the membrane potential against the
  distance and time to collision of the obstacle, and the camera's shake.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from matplotlib.colors import to_rgb

from lgmd_sim import metrics, models
from lgmd_sim.controllers import Straight, rollout
from lgmd_sim.fileio import atomic_output, write_files
from lgmd_sim.plots import model_style
from lgmd_sim.video import video_writer

SCENARIO = "lgmd_sim/RoughTerrainObstacles-v0"
#: Forward speed as a fraction of the robot's limit, and the heading gain (1/rad).
CRUISE, HEADING_GAIN = 0.6, 1.5
#: Height (pixels) of the membrane-potential panel under the video.
TRACE_HEIGHT = 210


@dataclass
class Episode:
    """What the demo recorded, frame by frame."""

    frames: list[np.ndarray]
    s_layers: list[np.ndarray]
    potential: np.ndarray
    threshold: float
    distance: np.ndarray
    ttc: np.ndarray
    shake: np.ndarray  # camera angular speed (rad/s)
    ssim: np.ndarray
    collision_frame: int | None
    fps: float
    model: str

    @property
    def before_collision(self) -> int:
        """The frame 0.5 s before the collision (or the last frame): at contact the
        obstacle fills the whole view."""
        if self.collision_frame is None:
            return len(self.potential) - 1
        return max(self.collision_frame - round(0.5 * self.fps), 0)


def drive(seed: int, jitter: float, model_name: str) -> Episode:
    """Run one episode with the robot heading for the goal through the obstacle ahead."""
    import gymnasium as gym

    import lgmd_sim  # noqa: F401  (registers the scenarios)

    model = models.make(model_name)
    env = gym.make(SCENARIO, jitter=jitter, resolution="paper")
    rec: dict[str, list] = {k: [] for k in ("frames", "s", "mp", "dist", "ttc", "shake",
                                            "ssim")}
    collision = None
    try:
        for step in rollout(env, Straight(cruise=CRUISE, heading_gain=HEADING_GAIN), seed):
            obs, info = step.obs, step.info
            out = model.step(obs["frame"], layers=True)
            rec["frames"].append(obs["frame"])
            rec["s"].append(out.layers["S"])
            rec["mp"].append(out.potential)
            rec["dist"].append(info["threat_distance"])
            rec["ttc"].append(info["threat_ttc"])
            rec["shake"].append(float(np.linalg.norm(info["camera_angvel"])))
            rec["ssim"].append(info["ssim"])
            if info["collision"] and collision is None:
                collision = step.index
    finally:
        env.close()
    return Episode(
        rec["frames"], rec["s"], np.array(rec["mp"]), model.params.threshold,
        np.array(rec["dist"]), np.array(rec["ttc"]), np.array(rec["shake"]),
        np.array(rec["ssim"], dtype=float), collision, float(env.metadata["render_fps"]),
        model_name,
    )


def _trace_panel(ep: Episode, upto: int, width: int) -> np.ndarray:
    """The membrane potential up to frame `upto`, drawn with OpenCV (fast, per frame)."""
    panel = np.full((TRACE_HEIGHT, width, 3), 255, np.uint8)
    n = len(ep.potential)
    left, right, top, bottom = 50, width - 10, 10, TRACE_HEIGHT - 25

    def xy(t: float, v: float) -> tuple[int, int]:
        x = left + (right - left) * t / max(n - 1, 1)
        y = bottom - (bottom - top) * (v - 0.5) / 0.5
        return round(x), round(y)

    font = cv2.FONT_HERSHEY_SIMPLEX
    cv2.rectangle(panel, (left, top), (right, bottom), (180, 180, 180), 1)
    for v in (0.5, 0.75, 1.0):
        cv2.putText(panel, f"{v:.2f}", (5, xy(0, v)[1] + 4), font, 0.4, (80, 80, 80), 1)
    cv2.line(panel, xy(0, ep.threshold), xy(n - 1, ep.threshold), (115, 115, 115), 1)
    cv2.putText(panel, f"threshold {ep.threshold:g}", (left + 5, xy(0, ep.threshold)[1] - 5),
                font, 0.4, (0, 0, 0), 1)
    if ep.collision_frame is not None:
        x = xy(ep.collision_frame, 0.5)[0]
        cv2.line(panel, (x, top), (x, bottom), (0, 0, 0), 1)
        cv2.putText(panel, "collision", (max(left, x - 70), top + 12), font, 0.4, (0, 0, 0), 1)
    pts = np.array([xy(t, v) for t, v in enumerate(ep.potential[: upto + 1])], np.int32)
    colour = tuple(round(255 * c) for c in to_rgb(model_style(ep.model)["color"]))
    cv2.polylines(panel, [pts.reshape(-1, 1, 2)], False, colour, 2, cv2.LINE_AA)
    cv2.putText(panel, f"frame {upto}   membrane potential {ep.potential[upto]:.3f}",
                (left, TRACE_HEIGHT - 8), font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    return panel


class _Compositor:
    """Frames of the video: camera | S layer on top, the potential trace below (RGB)."""

    def __init__(self, ep: Episode) -> None:
        self.ep = ep
        # One scale for the whole episode: S brightness compares across frames.
        self.s_scale = max(float(np.percentile(np.stack(ep.s_layers), 99.9)), 1e-6)

    def __call__(self, t: int) -> np.ndarray:
        frame, s = self.ep.frames[t], self.ep.s_layers[t]
        s8 = np.clip(255.0 * np.sqrt(s / self.s_scale), 0, 255).astype(np.uint8)
        s_rgb = cv2.cvtColor(cv2.applyColorMap(s8, cv2.COLORMAP_INFERNO), cv2.COLOR_BGR2RGB)
        cv2.putText(s_rgb, "S layer", (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
                    (255, 255, 255), 1, cv2.LINE_AA)
        return np.vstack([np.hstack([frame, s_rgb]), _trace_panel(self.ep, t, 2 * s.shape[1])])


def write_video(ep: Episode, path: Path, still: Path | None = None) -> None:
    """The episode as a video; with `still`, also its frame 0.5 s before the collision."""
    compose = _Compositor(ep)
    h, w = ep.frames[0].shape[:2]
    with video_writer(path, ep.fps, (h + TRACE_HEIGHT, 2 * w)) as write:
        for t in range(len(ep.frames)):
            write(compose(t))
    if still is not None:
        image = cv2.cvtColor(compose(ep.before_collision), cv2.COLOR_RGB2BGR)
        write_files({still: lambda tmp: _imwrite(tmp, image)})


def _imwrite(path: Path, bgr: np.ndarray) -> None:
    if not cv2.imwrite(str(path), bgr):
        raise OSError(f"cannot write image {path}")


def write_summary(ep: Episode, path: Path, title: str) -> None:
    """Key frames in time order, the potential against distance and time to collision of
    the obstacle, and the camera's shake."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from lgmd_sim.plots import COLLISION, THRESHOLD, model_style

    n = len(ep.potential)
    alarm = metrics.first_alarm(ep.potential, threshold=ep.threshold)
    end = ep.collision_frame if ep.collision_frame is not None else n - 1
    keys = {"start": 0, "midway": end // 2,
            "0.5 s before collision" if ep.collision_frame is not None else "last frame":
                ep.before_collision}
    if alarm is not None:
        keys["first alarm"] = alarm
    keys = dict(sorted(keys.items(), key=lambda kv: kv[1]))  # in time order
    fig = Figure(figsize=(11, 9), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(4, len(keys), height_ratios=[1.1, 1.4, 1, 0.8])
    for i, (label, t) in enumerate(keys.items()):
        ax = fig.add_subplot(grid[0, i])
        ax.imshow(ep.frames[t])
        ax.set_title(f"{label} (frame {t}, {t / ep.fps:.2f} s)", fontsize="small")
        ax.axis("off")
    time = np.arange(n) / ep.fps
    mp = fig.add_subplot(grid[1, :])
    style = model_style(ep.model)
    mp.plot(time, ep.potential, label="membrane potential", **style)
    if alarm is not None:
        mp.plot(time[alarm], ep.potential[alarm], marker="v", ms=9, color=style["color"],
                mec="black", ls="none", label=f"first alarm ({time[alarm]:.2f} s)")
    mp.axhline(ep.threshold, label=f"threshold {ep.threshold:g}", **THRESHOLD)
    mp.set_ylim(0.45, 1.02)
    mp.set_ylabel("membrane potential")
    gt = fig.add_subplot(grid[2, :], sharex=mp)
    finite = np.isfinite(ep.distance)
    gt.plot(time[finite], ep.distance[finite], color="#009E73", label="distance to obstacle")
    gt.set_ylabel("distance (m)")
    ttc = gt.twinx()
    ttc.plot(time, np.where(ep.ttc < 20, ep.ttc, np.nan), color="#E69F00", ls="--",
             label="time to collision (< 20 s)")
    ttc.set_ylabel("time to collision (s)")
    shake = fig.add_subplot(grid[3, :], sharex=mp)
    shake.plot(time, np.degrees(ep.shake), color="0.35", lw=1)
    shake.set_ylabel("camera rotation\nspeed (deg/s)")
    shake.set_xlabel("time (s)")
    for ax in (mp, gt, shake):
        if ep.collision_frame is not None:
            ax.axvline(ep.collision_frame / ep.fps, **COLLISION,
                       label="collision" if ax is mp else None)
    mp.legend(loc="upper left", fontsize="small")
    lines = gt.get_legend_handles_labels()
    twin = ttc.get_legend_handles_labels()
    gt.legend(lines[0] + twin[0], lines[1] + twin[1], loc="upper right", fontsize="small")
    isi = float(np.nanmean(ep.ssim[1:])) if n > 1 else math.nan
    fig.suptitle(f"{title}: ISI {isi:.3f}, MpSI {metrics.mpsi(ep.potential):.3f}")
    with atomic_output(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)


def run(args: argparse.Namespace) -> int:
    if args.model not in models.available():
        raise ValueError(f"unknown model {args.model!r}; available: "
                         f"{', '.join(models.available())}")
    out = Path(args.out)
    ep = drive(args.seed, args.jitter, args.model)
    video, summary, still = out / "demo.mp4", out / "demo.png", out / "demo_frame.png"
    write_video(ep, video, still)
    title = f"{args.model} LGMD, RoughTerrainObstacles, jitter {args.jitter:g}, seed {args.seed}"
    write_summary(ep, summary, title)
    hit = (f"collision at frame {ep.collision_frame}" if ep.collision_frame is not None
           else "no collision")
    alarm = metrics.first_alarm(ep.potential, threshold=ep.threshold)
    print(f"{len(ep.frames)} frames, {hit}, first alarm "
          f"{'none' if alarm is None else f'at frame {alarm}'}")
    print(f"video:   {video.resolve()}")
    print(f"summary: {summary.resolve()}")
    print(f"still:   {still.resolve()}")
    return 0
