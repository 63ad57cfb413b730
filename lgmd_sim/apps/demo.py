"""`lgmd-sim demo`: the robot drives straight at an obstacle over rough ground.

One episode of RoughTerrainObstacles at 120 x 160 (the robot presets' calibration's
size): a proportional heading controller keeps the robot on the line to the goal, with an
obstacle standing in the way, while LGMD detectors watch the camera: by default the
feedback LGMD at its robot preset beside the paper's (`lgmd_sim.apps.defaults`).
Writes

- ``demo.mp4``: the camera view beside the first detector's S layer, and below them every
  detector's membrane potential so far, with its threshold and the collision frame;
- ``demo.png``: a summary: frames at key moments, the membrane potentials against the
  distance and time to collision of the obstacle, and the camera's shake;

and, closing the loop, an episode in which the robot avoids the obstacles by itself
(`lgmd_sim.apps.avoid`: ``avoid.mp4``, ``avoid.png``). The files are written as a set: all
of them, or none; without the closed loop, an earlier run's two are removed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from matplotlib.colors import to_rgb

from lgmd_sim import models
from lgmd_sim.apps.defaults import AVOID_SEED, DETECTORS, SEED
from lgmd_sim.controllers import Straight, rollout
from lgmd_sim.core.fileio import atomic_folder_outputs, atomic_output, write_files
from lgmd_sim.core.params import FieldError
from lgmd_sim.core.plots import model_style
from lgmd_sim.core.pngtext import add_text, png_text
from lgmd_sim.envs.zone import CRUISE
from lgmd_sim.signals import metrics
from lgmd_sim.signals.video import video_writer

SCENARIO = "lgmd_sim/RoughTerrainObstacles-v0"
#: Forward speed as a fraction of the robot's limit, and the heading gain (1/rad).
HEADING_GAIN = 1.5
#: Height (pixels) of the membrane-potential panel under the video.
TRACE_HEIGHT = 210
#: Frames smaller than this are shown enlarged by a whole factor, pixels kept square and
#: sharp (nearest neighbour): a 120 x 160 camera is too small to watch at its own size.
SHOWN_HEIGHT = 240
#: Dash length (points) of the thresholds in the summary.
DASH = 4.0
#: The closed-loop episode's files (`lgmd_sim.apps.avoid`): the video, the figure.
AVOID_FILES = ("avoid.mp4", "avoid.png")


@dataclass
class Episode:
    """What the demo recorded, frame by frame; detectors by their spec, in order."""

    frames: list[np.ndarray]
    s_layers: list[np.ndarray]  # the first detector's
    potentials: dict[str, np.ndarray]
    thresholds: dict[str, float]
    distance: np.ndarray
    ttc: np.ndarray
    shake: np.ndarray  # camera angular speed (rad/s)
    ssim: np.ndarray
    collision_frame: int | None
    fps: float
    #: Per detector, when its potentials alarm.
    alarm_rules: dict[str, metrics.AlarmRule] = field(default_factory=dict)

    @property
    def before_collision(self) -> int:
        """The frame 0.5 s before the collision (or the last frame): at contact the
        obstacle fills the whole view."""
        if self.collision_frame is None:
            return len(self.frames) - 1
        return max(self.collision_frame - round(0.5 * self.fps), 0)

    def alarms(self, name: str) -> np.ndarray:
        """A detector's alarm in every frame."""
        rule = self.alarm_rules.get(name, metrics.PAPER_ALARM)
        return rule.series(self.potentials[name]) > self.thresholds[name]

    def first_alarm(self, name: str) -> int | None:
        return metrics.first_alarm(self.alarms(name))


def drive(seed: int, jitter: float, detectors: list[str],
          resolution: str | Sequence[int] = "rl") -> Episode:
    """Run one episode with the robot heading for the goal through the obstacle ahead,
    each detector ("model/preset+front", `models.parse_spec`) watching the camera."""
    import gymnasium as gym

    import lgmd_sim  # noqa: F401  (registers the scenarios)

    specs = {d: models.parse_spec(d) for d in detectors}
    built = {d: models.make(name, preset=preset) for d, (name, preset) in specs.items()}
    env = gym.make(SCENARIO, jitter=jitter, resolution=resolution, ssim=True)
    rec: dict[str, list] = {k: [] for k in ("frames", "s", "dist", "ttc", "shake", "ssim")}
    potentials: dict[str, list[float]] = {d: [] for d in detectors}
    collision = None
    try:
        for step in rollout(env, Straight(cruise=CRUISE, heading_gain=HEADING_GAIN), seed):
            obs, info = step.obs, step.info
            for k, (name, model) in enumerate(built.items()):
                out = model.step(obs["frame"], layers=k == 0,
                                 rotation=model.rotation_from(info))
                potentials[name].append(out.potential)
                if k == 0:
                    rec["s"].append(out.layers["S"])
            rec["frames"].append(obs["frame"])
            rec["dist"].append(info["threat_distance"])
            rec["ttc"].append(info["threat_ttc"])
            rec["shake"].append(float(np.linalg.norm(info["camera_angvel"])))
            rec["ssim"].append(info["ssim"])
            if info["collision"] and collision is None:
                collision = step.index
    finally:
        env.close()
    return Episode(
        rec["frames"], rec["s"], {d: np.array(v) for d, v in potentials.items()},
        {d: m.params.threshold for d, m in built.items()},
        np.array(rec["dist"]), np.array(rec["ttc"]), np.array(rec["shake"]),
        np.array(rec["ssim"], dtype=float), collision, float(env.metadata["render_fps"]),
        {d: m.alarm_rule for d, m in built.items()},
    )


def _rgb(name: str) -> tuple[int, ...]:
    return tuple(round(255 * c) for c in to_rgb(model_style(name)["color"]))


def _by_threshold(ep: Episode) -> dict[float, list[str]]:
    """The detectors of each threshold, in the episode's order."""
    shared: dict[float, list[str]] = {}
    for name, threshold in ep.thresholds.items():
        shared.setdefault(threshold, []).append(name)
    return shared


def _trace_panel(ep: Episode, upto: int, width: int) -> np.ndarray:
    """The membrane potentials up to frame `upto`, drawn with OpenCV (fast, per frame)."""
    panel = np.full((TRACE_HEIGHT, width, 3), 255, np.uint8)
    n = len(ep.frames)
    left, right, top, bottom = 50, width - 10, 10, TRACE_HEIGHT - 25

    def xy(t: float, v: float) -> tuple[int, int]:
        x = left + (right - left) * t / max(n - 1, 1)
        y = bottom - (bottom - top) * (v - 0.5) / 0.5
        return round(x), round(y)

    font = cv2.FONT_HERSHEY_SIMPLEX
    cv2.rectangle(panel, (left, top), (right, bottom), (180, 180, 180), 1)
    for v in (0.5, 0.75, 1.0):
        cv2.putText(panel, f"{v:.2f}", (5, xy(0, v)[1] + 4), font, 0.4, (80, 80, 80), 1)
    for threshold, names in _by_threshold(ep).items():
        y = xy(0, threshold)[1]
        # dashes in turn in the colours of the detectors whose threshold it is
        for i, x in enumerate(range(left, right, 6)):
            cv2.line(panel, (x, y), (min(x + 5, right), y), _rgb(names[i % len(names)]), 1)
        x = left + 5
        for text, colour in [*((f"{name} ", _rgb(name)) for name in names),
                             (f"threshold {threshold:g}", (0, 0, 0))]:
            cv2.putText(panel, text, (x, y - 5), font, 0.4, colour, 1, cv2.LINE_AA)
            x += cv2.getTextSize(text, font, 0.4, 1)[0][0]
    if ep.collision_frame is not None:
        x = xy(ep.collision_frame, 0.5)[0]
        cv2.line(panel, (x, top), (x, bottom), (0, 0, 0), 1)
        cv2.putText(panel, "collision", (max(left, x - 70), top + 12), font, 0.4, (0, 0, 0), 1)
    for k, (name, potential) in reversed(list(enumerate(ep.potentials.items()))):
        pts = np.array([xy(t, v) for t, v in enumerate(potential[: upto + 1])], np.int32)
        # the first detector on top and thicker: variants of one model share a hue
        cv2.polylines(panel, [pts.reshape(-1, 1, 2)], False, _rgb(name), 3 if k == 0 else 1,
                      cv2.LINE_AA)
    cv2.putText(panel, f"frame {upto}", (left, TRACE_HEIGHT - 8), font, 0.45, (0, 0, 0), 1,
                cv2.LINE_AA)
    x = left + 90
    for name, potential in ep.potentials.items():
        text = f"{name} {potential[upto]:.3f}"
        cv2.putText(panel, text, (x, TRACE_HEIGHT - 8), font, 0.45, _rgb(name), 1, cv2.LINE_AA)
        x += cv2.getTextSize(text, font, 0.45, 1)[0][0] + 25
    return panel


class _Compositor:
    """Frames of the video: camera | S layer on top, the potential trace below (RGB)."""

    def __init__(self, ep: Episode) -> None:
        self.ep = ep
        # One scale for the whole episode: S brightness compares across frames.
        self.s_scale = max(float(np.percentile(np.stack(ep.s_layers), 99.9)), 1e-6)
        h, w = ep.frames[0].shape[:2]
        self.zoom = max(1, SHOWN_HEIGHT // h)
        self.size = (self.zoom * h + TRACE_HEIGHT, 2 * self.zoom * w)

    def _shown(self, image: np.ndarray) -> np.ndarray:
        return cv2.resize(image, None, fx=self.zoom, fy=self.zoom,
                          interpolation=cv2.INTER_NEAREST)

    def __call__(self, t: int) -> np.ndarray:
        frame, s = self.ep.frames[t], self.ep.s_layers[t]
        s = np.maximum(s, 0)  # LGMD1's S is negative where inhibition wins
        s8 = np.clip(255.0 * np.sqrt(s / self.s_scale), 0, 255).astype(np.uint8)
        s_rgb = self._shown(cv2.cvtColor(cv2.applyColorMap(s8, cv2.COLORMAP_INFERNO),
                                         cv2.COLOR_BGR2RGB))
        cv2.putText(s_rgb, f"S layer of {next(iter(self.ep.potentials))}", (8, 20),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1, cv2.LINE_AA)
        return np.vstack([np.hstack([self._shown(frame), s_rgb]),
                          _trace_panel(self.ep, t, self.size[1])])


def write_video(ep: Episode, path: Path, still: Path | None = None,
                text: dict[str, str] | None = None) -> None:
    """The episode as a video; with `still`, also its frame 0.5 s before the collision
    (a PNG with the text chunks `text`, `lgmd_sim.core.pngtext`: what made it)."""
    compose = _Compositor(ep)
    with video_writer(path, ep.fps, compose.size) as write:
        for t in range(len(ep.frames)):
            write(compose(t))
    if still is not None:
        image = cv2.cvtColor(compose(ep.before_collision), cv2.COLOR_RGB2BGR)
        write_files({still: lambda tmp: _write_png(tmp, image, text or {})})


def _write_png(path: Path, bgr: np.ndarray, text: dict[str, str]) -> None:
    ok, png = cv2.imencode(".png", bgr)
    if not ok:
        raise OSError(f"cannot encode image {path}")
    path.write_bytes(add_text(png.tobytes(), text))


def write_summary(ep: Episode, path: Path, title: str,
                  text: dict[str, str] | None = None) -> None:
    """Key frames in time order, the potentials against distance and time to collision of
    the obstacle, and the camera's shake; the PNG with the text chunks `text`
    (`lgmd_sim.core.pngtext`: what made it)."""
    from lgmd_sim.core.plots import COLLISION, THRESHOLD, figure
    from lgmd_sim.detect.figure import alarm_label

    n = len(ep.frames)
    first = next(iter(ep.potentials))
    alarm = ep.first_alarm(first)
    end = ep.collision_frame if ep.collision_frame is not None else n - 1
    keys = {"start": 0, "midway": end // 2,
            "0.5 s before collision" if ep.collision_frame is not None else "last frame":
                ep.before_collision}
    if alarm is not None:
        keys[f"first alarm of {first}"] = alarm
    keys = dict(sorted(keys.items(), key=lambda kv: kv[1]))  # in time order
    fig = figure(figsize=(11, 9))
    grid = fig.add_gridspec(4, len(keys), height_ratios=[1.1, 1.4, 1, 0.8])
    for i, (label, t) in enumerate(keys.items()):
        ax = fig.add_subplot(grid[0, i])
        ax.imshow(ep.frames[t])
        ax.set_title(f"{label}\n(frame {t}, {t / ep.fps:.2f} s)", fontsize="small")
        ax.axis("off")
    time = np.arange(n) / ep.fps
    mp = fig.add_subplot(grid[1, :])
    for name, potential in ep.potentials.items():
        style = model_style(name)
        t = ep.first_alarm(name)
        event = (None if ep.collision_frame is None else metrics.evaluate_clip(
            ep.alarms(name), ep.collision_frame, ep.fps))
        mp.plot(time, potential, label=alarm_label(name, t, event), **style)
        if t is not None:
            mp.plot(time[t], potential[t], marker="v", ms=9, color=style["color"],
                    mec="black", ls="none")
    for threshold, names in _by_threshold(ep).items():
        # one line per detector, in its colour; where thresholds coincide, their dashes
        # alternate so that each stays visible
        gap = DASH * max(len(names) - 1, 1)
        for k, name in enumerate(names):
            mp.axhline(threshold, label=f"threshold of {name}: {threshold:g}",
                       **{**THRESHOLD, "color": model_style(name)["color"], "lw": 1.3,
                          "ls": (k * DASH, (DASH, gap))})
    mp.set_ylim(0.45, 1.32)  # the band above 1 holds the legend: potentials stay below it
    mp.set_yticks(np.arange(0.5, 1.01, 0.1))
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
    mp.legend(loc="upper center", ncols=2, fontsize="small", title_fontsize="small",
              title="first alarm (frame), outcome" if ep.collision_frame is not None
              else "first alarm (frame)")
    lines = gt.get_legend_handles_labels()
    twin = ttc.get_legend_handles_labels()
    gt.legend(lines[0] + twin[0], lines[1] + twin[1], loc="upper right", fontsize="small")
    isi = float(np.nanmean(ep.ssim[1:])) if n > 1 else math.nan
    mpsi = ", ".join(f"{name} {metrics.mpsi(p):.3f}" for name, p in ep.potentials.items())
    fig.suptitle(f"{title}\nISI {isi:.3f}; MpSI: {mpsi}")
    with atomic_output(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100, metadata=text)


def configuration(*, seed: int = SEED, jitter: float = 1.0,
                  detectors: Sequence[str] = DETECTORS,
                  resolution: str | Sequence[int] = "rl", avoider: str | None = None,
                  avoid_seed: int = AVOID_SEED,
                  avoid_resolution: str | Sequence[int] | None = None) -> dict[str, Any]:
    """The episodes `run` shows, given its arguments (but `out`), JSON-ready: what every
    figure it writes records of its making (`lgmd_sim.core.pngtext`), so that a figure can
    be told from what the command makes today."""
    def res(r: str | Sequence[int] | None) -> str | list[int] | None:
        return r if r is None or isinstance(r, str) else [int(v) for v in r]

    from lgmd_sim.core.numerics import mode

    return {"numerics": mode(), "seed": int(seed), "jitter": float(jitter),
            "detectors": list(detectors),
            "resolution": res(resolution), "avoider": avoider,
            "avoid_seed": None if avoider is None else int(avoid_seed),
            "avoid_resolution": None if avoider is None else res(avoid_resolution)}


def run(*, out: str | Path = "demo-out", seed: int = SEED, jitter: float = 1.0,
        detectors: Sequence[str] = DETECTORS,
        resolution: str | Sequence[int] = "rl", avoider: str | None = None,
        avoid_seed: int = AVOID_SEED, avoid_resolution: str | Sequence[int] | None = None,
        command: str | None = None) -> int:
    """Drive one episode with `detectors` watching (the first one's S layer shown) at the
    camera `resolution`, and with `avoider` ("DETECTOR[,HOW]", `demo_avoid.parse_avoider`;
    None: not) one in which that detector drives the robot round the obstacles
    (`lgmd_sim.apps.avoid`), seeded `avoid_seed`, at `avoid_resolution` (None: the
    closed-loop benchmark's); write the videos, the summaries and the still into `out`,
    all of them or (on an error) none (without `avoider`, an earlier run's avoiding
    episode there is removed), each PNG with the `command` that made it (the command line,
    None: none) and the `configuration` (PNG text chunks, `lgmd_sim.core.pngtext`); print
    where they are."""
    from lgmd_sim.apps import avoid as demo_avoid

    detectors = list(detectors)
    if not detectors:
        raise FieldError("models", "must give at least one detector")
    for d in detectors:
        models.parse_spec(d)  # an unknown model, preset or front end: before the episode
    closed = None if avoider is None else demo_avoid.parse_avoider(avoider)
    out = Path(out)
    ep = drive(seed, jitter, detectors, resolution)
    avoid = (None if closed is None
             else demo_avoid.drive(avoid_seed, jitter, *closed, resolution=avoid_resolution))
    text = png_text(command, configuration(
        seed=seed, jitter=jitter, detectors=detectors, resolution=resolution, avoider=avoider,
        avoid_seed=avoid_seed, avoid_resolution=avoid_resolution))
    names = ["demo.mp4", "demo_frame.png", "demo.png"]
    names += [] if avoid is None else list(AVOID_FILES)
    with atomic_folder_outputs(out, names) as staging:
        write_video(ep, staging / names[0], staging / names[1], text)
        write_summary(ep, staging / names[2],
                      f"RoughTerrainObstacles, jitter {jitter:g}, seed {seed}", text)
        if avoid is not None:
            demo_avoid.write(avoid, staging / names[3], staging / names[4], text)
    if avoid is None:  # an earlier run's would read as this one's: the folder is one set
        for name in AVOID_FILES:
            (out / name).unlink(missing_ok=True)
    hit = (f"collision at frame {ep.collision_frame}" if ep.collision_frame is not None
           else "no collision")
    print(f"{len(ep.frames)} frames, {hit}")
    for name in detectors:
        alarm = ep.first_alarm(name)
        print(f"  {name}: first alarm {'none' if alarm is None else f'at frame {alarm}'}")
    if avoid is not None:
        print(f"avoiding ({avoid.detector}, {avoid.how}, seed {avoid_seed}): "
              f"{len(avoid.frames)} frames, {avoid.outcome}, {len(avoid.onsets)} alarm(s) "
              f"at frame(s) {', '.join(map(str, avoid.onsets)) or 'none'}")
    for label, name in [("video", "demo.mp4"), ("summary", "demo.png"),
                        ("still", "demo_frame.png"), ("avoiding", "avoid.mp4"),
                        ("from above", "avoid.png")][:len(names)]:
        print(f"{label + ':':11} {(out / name).resolve()}")
    return 0
