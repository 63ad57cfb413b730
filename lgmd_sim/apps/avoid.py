"""`lgmd-sim demo`'s closed-loop part: the robot avoids the obstacles by itself.

One episode of RoughTerrainObstacles driven by a detector watching the camera (through
`LoomSteer` by default, or `ReactiveAvoid`), at the closed-loop benchmark's resolution and
cruise (its detectors' presets are calibrated there). Writes

- ``avoid.png``: the episode from above (terrain, obstacles, goal as the benchmark's
  trajectories figure draws them), the robot's path with its manoeuvres and each alarm's
  onset, beside the detector's membrane potential and the time to collision of the
  world's threat (the most threatening obstacle or wall: one touched, else the soonest to
  collide, else the nearest);
- ``avoid.mp4``: the camera view beside the top view with the path so far.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim import models
from lgmd_sim.benchmark.entries import REFERENCE, SIDES, driver
from lgmd_sim.core.params import FieldError
from lgmd_sim.signals.metrics import alarm_onsets

if TYPE_CHECKING:
    from matplotlib.figure import Figure

SCENARIO = "lgmd_sim/RoughTerrainObstacles-v0"
#: The time to collision drawn, clipped to this (s): further threats are no threat yet.
TTC_CLIP = 5.0
#: The path, its manoeuvres and the alarm onsets, in the figure and the video alike.
PATH_COLOUR, MANOEUVRE_COLOUR = "#0072B2", "#E69F00"
#: The time to collision's line: grey, no model's colour (not to be read as a detector's).
TTC_COLOUR = "0.35"
ALARM_MARK: dict[str, Any] = {"marker": "v", "ms": 10, "color": "#D62728", "mec": "black",
                              "ls": "none"}
#: The goal, as the benchmark's trajectories figure marks it.
GOAL_MARK: dict[str, Any] = {"marker": "*", "ms": 16, "color": "gold", "mec": "black",
                             "ls": "none", "zorder": 4}
#: The camera view's scale in the video (the benchmark's frames are small), and the most
#: width of the top view beside it, in multiples of its height.
VIDEO_SCALE, MAX_MAP_ASPECT = 3, 2.0
#: Height (pixels) of the band of text over the camera view.
BAND = 56


@dataclass
class AvoidEpisode:
    """What the closed-loop episode recorded, frame by frame. On the last frame the
    controller does not act: its potential is NaN there, its alarm and manoeuvre off."""

    detector: str
    how: str  # ReactiveAvoid's side ("halves", "eyes"), or the controller's name
    seed: int
    jitter: float
    frames: list[np.ndarray]
    path: np.ndarray  # (n, 2): the robot's (x, y) (m)
    potential: np.ndarray  # the controller's (of the more excited eye, with two)
    threshold: float
    alarm: np.ndarray  # controller.alarm
    manoeuvring: np.ndarray  # controller.manoeuvring
    ttc: np.ndarray  # ground truth: the world's threat's time to collision (s)
    collision_frame: int | None
    goal_reached: bool
    view: dict[str, Any]  # the world's top_view()
    fps: float

    @property
    def onsets(self) -> np.ndarray:
        """The frames where the controller's alarm turns on."""
        return alarm_onsets(self.alarm)

    @property
    def outcome(self) -> str:
        if self.collision_frame is not None:
            return "collided"
        return "goal reached" if self.goal_reached else "timed out"


def parse_avoider(text: str) -> tuple[str, str]:
    """"DETECTOR[,HOW]" -> (detector, how): a detector ("model/preset+front",
    `models.parse_spec`) and how it drives: `ReactiveAvoid` telling the threat's side by
    "halves" or "eyes" (none: `ReactiveParams`' default), or another controller that a
    detector drives ("loom-steer"). ValueError, one line naming `text`, where either is
    unknown."""
    from lgmd_sim import controllers

    detector, _, how = (t.strip() for t in text.partition(","))
    try:
        name, preset = models.parse_spec(detector)
        controller, params = _controller(name, preset, how or None)
        controllers.controller_class(controller).resolve(**params)  # checked; no model made
    except ValueError as exc:
        raise FieldError("avoider", f"{text!r}: {exc}") from None
    return detector, how or SIDES[0]


def _controller(name: str, preset: str, how: str | None) -> tuple[str, dict[str, Any]]:
    """The controller of "DETECTOR,HOW" (`parse_avoider`) and its parameters."""
    try:
        controller, side = driver(how or SIDES[0])
    except ValueError as exc:
        raise ValueError(f"after ',' comes {exc}") from None
    return controller, {"model": name, "preset": preset,
                        **({"side": side} if controller == REFERENCE else {})}


def drive(seed: int, jitter: float, detector: str, how: str | None = None,
          resolution: str | Sequence[int] | None = None) -> AvoidEpisode:
    """Run one episode with `detector` ("model/preset+front", `models.parse_spec`) driving
    as `how` says (`parse_avoider`; None: `ReactiveAvoid` at its default side), at
    `resolution` (None: the closed-loop benchmark's)."""
    import gymnasium as gym

    import lgmd_sim  # noqa: F401  (registers the scenarios)
    from lgmd_sim import controllers
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    name, preset = models.parse_spec(detector)
    bench = ClosedLoopConfig()
    kind, params = _controller(name, preset, how)
    controller = controllers.make(kind, **params, cruise=bench.cruise)
    how = how or SIDES[0]
    env = gym.make(SCENARIO, jitter=jitter,
                   resolution=bench.resolution if resolution is None else resolution)
    frames, xy, potential, alarm, manoeuvring, ttc = [], [], [], [], [], []
    try:
        for step in controllers.rollout(env, controller, seed=seed):
            acted = step.action is not None
            frames.append(step.obs["frame"])
            xy.append(step.info["carrier_pos"][:2])
            potential.append(controller.potential if acted else np.nan)
            alarm.append(acted and controller.alarm)
            manoeuvring.append(acted and controller.manoeuvring)
            ttc.append(step.info["threat_ttc"])
        last = step.info
        view = env.unwrapped.world.top_view()
    finally:
        env.close()
    collision = int(last["first_collision_frame"])
    return AvoidEpisode(
        detector, how, seed, jitter, frames, np.array(xy, float), np.array(potential, float),
        float(controller.model.params.threshold), np.array(alarm), np.array(manoeuvring),
        np.array(ttc, float), collision if collision >= 0 else None,
        bool(last["goal_reached"]), view, float(env.metadata["render_fps"]))


def _top_view_bounds(ep: AvoidEpisode) -> np.ndarray:
    """(x0, y0), (x1, y1) around the path, the obstacles and the goal."""
    from lgmd_sim.benchmark.drawing import map_bounds

    return map_bounds([{"top_view": {**ep.view, "path": ep.path}}])


def _draw_goal(ax, view: dict[str, Any], label: str | None = None) -> None:
    """The goal's star on a map of `view` (the world's top_view()), where it has one."""
    if view["goal"]:
        ax.plot(*view["goal"], **GOAL_MARK, label=label)


def _runs(mask: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """`xy` where `mask` holds, each run joined to the point after it (so that a run of
    one frame is a segment), NaN elsewhere: lines of the masked stretches."""
    keep = mask | np.r_[False, mask[:-1]]
    return np.where(keep[:, None], xy, np.nan)


def figure(ep: AvoidEpisode) -> Figure:
    """The episode from above beside the detector's potential and the threat's time to
    collision against time; each alarm onset numbered on both."""
    from matplotlib import patheffects

    from lgmd_sim.benchmark.drawing import draw_world
    from lgmd_sim.core.plots import COLLISION, figure, model_style
    from lgmd_sim.detect.figure import draw_thresholds

    (x0, y0), (x1, y1) = _top_view_bounds(ep)
    width = 6.0  # inches of the map; its height follows the extent (equal axes)
    height = float(np.clip(width * (y1 - y0) / (x1 - x0), 3.0, 6.0))
    fig = figure(figsize=(width + 7.0, height + 1.2))
    top, trace = fig.subplots(1, 2, width_ratios=[width, 6.5])
    draw_world(top, ep.view)
    onsets = ep.onsets
    halo = [patheffects.withStroke(linewidth=3, foreground="white")]
    # under the path, wide and round: the robot turns almost on the spot, a disc around
    # the alarm's mark
    top.plot(*_runs(ep.manoeuvring, ep.path).T, color=MANOEUVRE_COLOUR, lw=16,
             solid_capstyle="round", label="manoeuvre (braking, turning away)", zorder=2)
    top.plot(*ep.path.T, color=PATH_COLOUR, lw=1.6, label="path", zorder=3)
    top.plot(*ep.path[0], marker="o", ms=7, color=PATH_COLOUR, mec="black", ls="none",
             label="start", zorder=4)
    top.plot(*ep.path[onsets].T, **ALARM_MARK, label="alarm onset", zorder=5)
    for k, (x, y) in enumerate(ep.path[onsets], 1):
        top.annotate(str(k), (x, y), xytext=(6, 6), textcoords="offset points",
                     fontsize="small", weight="bold", path_effects=halo, zorder=6)
    if ep.collision_frame is not None:
        top.plot(*ep.path[ep.collision_frame], marker="X", ms=13, color="black",
                 mec="white", ls="none", label="collision", zorder=6)
    _draw_goal(top, ep.view, label="goal")
    top.set(xlim=(x0, x1), ylim=(y0, y1), aspect="equal", xlabel="x (m)", ylabel="y (m)",
            title="from above (obstacles brown, terrain height grey)")
    # below the x axis' label, not on it
    top.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncols=3, fontsize="small")

    time = np.arange(len(ep.frames)) / ep.fps
    colour = model_style(ep.detector)["color"]
    eye = " (the more excited eye)" if ep.how != "halves" else ""
    trace.plot(time, ep.potential, color=colour, lw=1.6,
               label=f"potential of {ep.detector}{eye}")
    # its value not beside the right edge: the time to collision's axis is there
    draw_thresholds(trace, {ep.detector: ep.threshold}, values=False)
    for k, t in enumerate(onsets, 1):
        trace.annotate(str(k), (time[t], ep.potential[t]), xytext=(0, 9),
                       textcoords="offset points", ha="center", fontsize="small",
                       weight="bold", path_effects=halo)
    trace.plot(time[onsets], ep.potential[onsets], **ALARM_MARK, label="alarm onset")
    for k, (a, b) in enumerate(_spans(ep.manoeuvring)):
        trace.axvspan(time[a], (b + 1) / ep.fps, color=MANOEUVRE_COLOUR, alpha=0.25, lw=0,
                      label="manoeuvre" if k == 0 else None)
    if ep.collision_frame is not None:
        trace.axvline(time[ep.collision_frame], **COLLISION, label="collision")
    trace.set(xlabel="time (s)", ylabel="membrane potential", xlim=(0, time[-1]),
              title="the detector, and the ground truth")
    ttc = trace.twinx()
    ttc.plot(time, np.where(ep.ttc < TTC_CLIP, ep.ttc, np.nan), color=TTC_COLOUR, lw=1.2,
             ls="--", label="time to collision of the most threatening obstacle "
             f"(< {TTC_CLIP:g} s)")
    ttc.set(ylim=(0, TTC_CLIP * 1.6), ylabel="time to collision (s)")
    lines, twin = trace.get_legend_handles_labels(), ttc.get_legend_handles_labels()
    trace.legend(lines[0] + twin[0], lines[1] + twin[1], loc="upper center",
                 bbox_to_anchor=(0.5, -0.16), ncols=2, fontsize="small")
    n = len(onsets)
    driver = (f"ReactiveAvoid driven by {ep.detector} ({ep.how})" if ep.how in SIDES
              else f"{ep.how} driven by {ep.detector}")
    fig.suptitle(f"{driver}: RoughTerrainObstacles, "
                 f"seed {ep.seed}, jitter {ep.jitter:g}: {ep.outcome}, "
                 f"{n} alarm{'' if n == 1 else 's'}")
    return fig


def _spans(mask: np.ndarray) -> list[tuple[int, int]]:
    """The (first, last) frames of each run of True in `mask`."""
    from lgmd_sim.benchmark.encounters import runs

    return runs(mask, np.arange(len(mask)), gap=0.0)


def _rgb(colour: str) -> tuple[int, ...]:
    from matplotlib.colors import to_rgb

    return tuple(round(255 * c) for c in to_rgb(colour))


class _Compositor:
    """Frames of the video: the camera view (scaled up) beside the top view with the path
    so far, its manoeuvres and alarm onsets (RGB). The map's world is drawn once."""

    def __init__(self, ep: AvoidEpisode) -> None:
        from lgmd_sim.benchmark.drawing import draw_world
        from lgmd_sim.core.plots import figure

        self.ep = ep
        h, w = ep.frames[0].shape[:2]
        self.height = _even(VIDEO_SCALE * h)
        self.camera_width = _even(VIDEO_SCALE * w)
        (x0, y0), (x1, y1) = _top_view_bounds(ep)
        map_width = _even(self.height * min((x1 - x0) / (y1 - y0), MAX_MAP_ASPECT))
        # one scale on both axes: a map that would be wider shows more of y instead
        per_metre = map_width / (x1 - x0)
        centre, half = (y0 + y1) / 2, self.height / per_metre / 2
        fig = figure(figsize=(map_width / 100, self.height / 100), dpi=100)
        fig.set_layout_engine("none")
        ax = fig.add_axes((0, 0, 1, 1))
        draw_world(ax, ep.view)
        _draw_goal(ax, ep.view)
        ax.set(xlim=(x0, x1), ylim=(centre - half, centre + half))
        ax.set_axis_off()
        fig.canvas.draw()
        self.world = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
        self.pixels = np.round((ep.path - [x0, centre + half]) * [1, -1]
                               * per_metre).astype(np.int32)

    @property
    def size(self) -> tuple[int, int]:
        return self.height, self.camera_width + self.world.shape[1]

    def __call__(self, t: int) -> np.ndarray:
        import cv2

        ep, font = self.ep, cv2.FONT_HERSHEY_SIMPLEX
        camera = cv2.resize(ep.frames[t], (self.camera_width, self.height),
                            interpolation=cv2.INTER_LINEAR)
        camera[:BAND] //= 3  # a dark band under the text, whatever the sky's colour
        status = f"{t / ep.fps:5.1f} s"
        if np.isfinite(ep.potential[t]):  # not on the last frame, where it does not act
            status += f"  potential {ep.potential[t]:.3f} (threshold {ep.threshold:g})"
        cv2.putText(camera, status, (8, 20), font, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
        x = 8
        for on, text, colour in [(ep.alarm[t], "ALARM", ALARM_MARK["color"]),
                                 (ep.manoeuvring[t], "MANOEUVRE", MANOEUVRE_COLOUR)]:
            if on:
                cv2.putText(camera, text, (x, 46), font, 0.65, _rgb(colour), 2, cv2.LINE_AA)
            x += 110
        top = self.world.copy()
        pts = self.pixels[: t + 1]
        for a, b in _spans(ep.manoeuvring[: t + 1]):
            run = self.pixels[a: b + 2]
            cv2.polylines(top, [run.reshape(-1, 1, 2)], False, _rgb(MANOEUVRE_COLOUR), 16,
                          cv2.LINE_AA)
        cv2.polylines(top, [pts.reshape(-1, 1, 2)], False, _rgb(PATH_COLOUR), 2, cv2.LINE_AA)
        for o in ep.onsets[ep.onsets <= t]:
            cv2.drawMarker(top, tuple(map(int, self.pixels[o])), _rgb(ALARM_MARK["color"]),
                           cv2.MARKER_TRIANGLE_DOWN, 12, 2, cv2.LINE_AA)
        if ep.collision_frame is not None and t >= ep.collision_frame:
            cv2.drawMarker(top, tuple(map(int, self.pixels[ep.collision_frame])), (0, 0, 0),
                           cv2.MARKER_TILTED_CROSS, 16, 3, cv2.LINE_AA)
        cv2.circle(top, tuple(map(int, pts[-1])), 3, (0, 0, 0), -1, cv2.LINE_AA)
        cv2.putText(top, ep.outcome if t == len(ep.frames) - 1 else "from above", (8, 22),
                    font, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
        return np.hstack([camera, top])


def _even(n: float) -> int:
    """A video dimension: even (the encoders' chroma subsampling)."""
    return max(2, 2 * round(n / 2))


def write(ep: AvoidEpisode, video: Path, summary: Path,
          text: dict[str, str] | None = None) -> None:
    """The episode's video and figure (`figure`), the figure with the PNG text chunks
    `text` (`lgmd_sim.core.pngtext`: what made it)."""
    from lgmd_sim.core.fileio import atomic_output
    from lgmd_sim.signals.video import video_writer

    compose = _Compositor(ep)
    with video_writer(video, ep.fps, compose.size) as write_frame:
        for t in range(len(ep.frames)):
            write_frame(compose(t))
    fig = figure(ep)
    with atomic_output(summary) as tmp:
        fig.savefig(tmp, format="png", dpi=100, metadata=text)
