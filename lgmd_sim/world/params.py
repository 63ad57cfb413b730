"""The parameters of a jitter world: named, defaulted with a source, checked on creation.

Every scenario of the catalogue (envs/*.toml) is a set of overrides of these defaults, and
``gym.make(id, **overrides)`` overrides them again. This module does not import MuJoCo, so
that the catalogue can list and check parameters cheaply.

The common jitter scale
-----------------------
``jitter`` is one number for every carrier: 0 is a steady camera, 1 a typical rough-ground
or hand-held level, larger is stronger. It sets the terrain roughness of the `robot`
carrier (``jitter * ROUGHNESS_PER_JITTER`` metres RMS) and the shake of the `handheld`
and `tripod` carriers (``jitter * SHAKE_PER_JITTER`` degrees RMS rotation plus
``jitter * SHIFT_PER_JITTER`` metres RMS translation). The two constants are calibrated so
that jitter 1 gives camera streams with an ISI (mean SSIM of consecutive frames) near the
paper's jitter streams (0.63 to 0.76, Table 2) at 270 x 480; explicit ``roughness`` or
``shake`` values override the mapping.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from lgmd_sim.core.params import (
    CheckedParams,
    FieldError,
    in_range,
    int_in_range,
    one_of,
    optional,
    param,
    positive,
    tuple_of,
)
from lgmd_sim.world import terrain

#: Terrain RMS height (m) per unit of jitter for the robot carrier (calibrated, see above).
ROUGHNESS_PER_JITTER = 0.008
#: Hand-held / tripod shake: RMS rotation (degrees) per unit of jitter (calibrated).
SHAKE_PER_JITTER = 1.1
#: Hand-held / tripod shake: RMS translation (m) per unit of jitter.
SHIFT_PER_JITTER = 0.006
#: Strongest jitter accepted: 5 is a violent shake, far past the paper's jitter streams.
MAX_JITTER = 5.0

#: Named frame sizes (height, width).
RESOLUTIONS: dict[str, tuple[int, int]] = {
    "paper": (270, 480),  # paper Sec. 4.1.2: the recorded streams are 270 x 480 at 30 fps
    "rl": (120, 160),
    "small": (64, 64),
}
#: Largest frame side accepted (4K); larger would exhaust memory before it helps anyone.
MAX_SIDE = 3840
#: Smallest frame side: the SSIM window (11 x 11) must fit.
MIN_SIDE = 16

#: Most terrain tiles (each two heightfields) a world may have: 40 x 40 m at 0.1 m cells.
MAX_TILES = 400
#: Most static obstacles and scenery objects: far beyond any scenario, still built in
#: well under a second (MuJoCo fails outright near 2000 obstacles).
MAX_OBSTACLES, MAX_SCENERY = 200, 500
#: Farthest distance (m) of anything placed by parameter: the goal, the obstacle field.
MAX_DISTANCE = 1000.0
#: The rough patch (and the arena walls around it) starts this far behind the start (m).
ARENA_BACK = 2.0
#: Least gap (m) between a static obstacle's footprint and the arena walls, and between
#: the start and the walls: room for the robot (its footprint 0.34 m across) to pass and turn.
WALL_GAP = 0.6
CARRIERS = ("robot", "handheld", "tripod")
OBSTACLE_KINDS = ("box", "cylinder", "wall", "balloon")
MOVERS = ("none", "balloon", "ball", "swing", "vehicle")


def frame_size(resolution: str | Sequence[int]) -> tuple[int, int]:
    """The (height, width) of a resolution: a name of `RESOLUTIONS`, "HEIGHTxWIDTH" or
    (height, width); ValueError where a string is neither name nor size."""
    if isinstance(resolution, str):
        resolution = parse_resolution(resolution)
        if isinstance(resolution, str):
            return RESOLUTIONS[resolution]
    return int(resolution[0]), int(resolution[1])


def parse_pair(text: str) -> tuple[int, int] | None:
    """"AxB" (or "AXB") as two integers, or None where `text` is not that: how a frame size
    ("270x480") or a grid ("3x5") is written on the command line."""
    try:
        a, b = (int(v) for v in text.lower().split("x"))
    except ValueError:
        return None
    return a, b


#: What a resolution may be, as messages say it.
_RESOLUTION_FORMS = (f"must be {', '.join(RESOLUTIONS)}, HEIGHTxWIDTH (e.g. 270x480) or "
                     f"[height, width], each side {MIN_SIDE} to {MAX_SIDE}")


def _resolution(v: Any) -> str | tuple[int, int] | None:
    """`v` as parameters keep it (a name, or (height, width)), or None where it is no
    frame size."""
    if isinstance(v, str):
        if v in RESOLUTIONS:
            return v
        v = parse_pair(v)
    if tuple_of(int_in_range(MIN_SIDE, MAX_SIDE), 2)(v):
        return None
    return int(v[0]), int(v[1])


def parse_resolution(value: Any, field: str = "resolution") -> str | tuple[int, int]:
    """The frame size `value` as the tool keeps it: a name of `RESOLUTIONS` as it is, or
    (height, width) from [height, width] or "HEIGHTxWIDTH" ("270x480", "270X480"). The
    command line's --resolution and the Python API (``gym.make``, the configurations)
    take the same spellings through it.

    Raises:
        FieldError: anything else, one line naming `field` and the value.
    """
    size = _resolution(value)
    if size is None:
        raise FieldError(field, f"{_RESOLUTION_FORMS}, got {value!r}")
    return size


def resolution_check(v: Any) -> str | None:
    """`SceneParams.resolution`'s check: None where `v` is a frame size (any spelling of
    `parse_resolution`), else what one must be."""
    return None if _resolution(v) is not None else _RESOLUTION_FORMS


def kinds_check(v: Any) -> str | None:
    error = tuple_of(one_of(*OBSTACLE_KINDS), min_length=1)(v)
    return f"must list kinds among {', '.join(OBSTACLE_KINDS)}" if error else None


DESIGN = "design choice"


@dataclass(frozen=True)
class SceneParams(CheckedParams):
    """What the world contains and how it is seen."""

    # -- camera carrier and jitter --------------------------------------------------------
    carrier: str = param("robot", DESIGN, check=one_of(*CARRIERS),
                         doc="what carries the camera: robot, handheld or tripod")
    jitter: float = param(1.0, "common jitter scale (see lgmd_sim.world.params)",
                          check=in_range(0.0, MAX_JITTER),
                          doc="0 steady, 1 typical rough ground / hand-held, larger stronger")
    roughness: float | None = param(
        None, f"jitter x {ROUGHNESS_PER_JITTER} m for the robot carrier, else 0",
        check=optional(in_range(0.0, MAX_JITTER * ROUGHNESS_PER_JITTER)),
        doc="terrain RMS height (m); 0 is flat ground")
    terrain_scale: float = param(0.5, DESIGN, check=in_range(0.05, 50.0),
                                 doc="spatial scale of the terrain bumps (m)")
    terrain_cell: float = param(
        0.1, "design: fine enough for 6 cm wheels, coarse enough to render fast",
        check=in_range(0.02, 2.0), doc="heightfield grid spacing (m)")
    arena: tuple[float, float] = param(
        (12.0, 8.0), DESIGN, check=tuple_of(in_range(1.0, 200.0), 2),
        doc="length (along the start heading) and width of the rough patch (m), rounded up to "
            "whole drawing tiles of 20 cells")
    shake: float | None = param(
        None, f"jitter x {SHAKE_PER_JITTER} deg for handheld and tripod carriers, else 0",
        check=optional(in_range(0.0, MAX_JITTER * SHAKE_PER_JITTER)),
        doc="RMS rotation of the camera shake (degrees)")
    shake_band: tuple[float, float] = param(
        (0.8, 7.0), "hand tremor and gait sway lie within about 1 to 8 Hz",
        check=tuple_of(in_range(0.05, 14.0), 2), doc="frequency band of the shake (Hz)")
    max_speed: float = param(1.0, "a small outdoor robot / walking pace", check=in_range(0.01, 20),
                             doc="linear velocity at action +1 (m/s)")
    max_turn: float = param(2.0, DESIGN, check=in_range(0.01, 20),
                            doc="angular velocity at action +1 (rad/s)")
    camera_height: float = param(1.2, "a camera held at chest height / on a tripod",
                                 check=in_range(0.05, 10.0),
                                 doc="camera height of the handheld and tripod carriers (m)")
    # -- camera and rendering --------------------------------------------------------------
    resolution: str | tuple[int, int] = param(
        "rl", "presets: paper 270x480 (Sec. 4.1.2), rl 120x160, small 64x64",
        check=resolution_check, doc="preset name, \"HEIGHTxWIDTH\" or [height, width]")
    fovy: float = param(55.0, "about a GoPro's linear field of view (Sec. 4.1.2's camera)",
                        check=in_range(10.0, 150.0), doc="vertical field of view (degrees)")
    frame: str = param("rgb", "design; none: the privileged teacher needs no frames, and "
                       "rendering is most of a step's cost", check=one_of("rgb", "grey", "none"),
                       doc="observed frame: rgb (H, W, 3), grey (H, W, 1) or none (nothing "
                           "rendered, no frame observed, info ssim NaN)")
    fps: float = param(30.0, "paper Sec. 4.1.2: 30 frames per second", check=in_range(1, 1000),
                       doc="camera frame rate; one env step per frame")
    substeps: int = param(8, "design: 4.2 ms physics steps at 30 fps",
                          check=int_in_range(1, 1000), doc="physics steps per frame")
    shadows: bool = param(False, "software GL: shadows cost more than the whole frame",
                          check=one_of(True, False), doc="render shadows")
    multisample: int = param(0, "software GL: no multisampling",
                             check=int_in_range(0, 16),
                             doc="multisample anti-aliasing samples")
    render_camera: str = param("camera", DESIGN, check=one_of("camera", "chase"),
                               doc="what render() shows: the carrier's camera or a chase view")
    # -- IMU (info["imu_rotation"] and the proprioception) ------------------------------------
    gyro_noise: float = param(
        0.0, "ours: 0, an ideal gyro; MEMS gyros: about 0.004 to 0.015 deg/s/sqrt(Hz) (Bosch "
        "BMI088 datasheet: 0.014)", check=in_range(0.0, 10.0),
        doc="white noise density of the gyro integrated into imu_rotation (deg/s/sqrt(Hz)), "
            "drawn every physics step from the episode's seed")
    gyro_bias: float = param(
        0.0, "ours: 0, a calibrated gyro; uncalibrated MEMS zero-rate offsets reach about "
        "1 deg/s (Bosch BMI088 datasheet: +-1 deg/s)", check=in_range(0.0, 100.0),
        doc="RMS per axis of the gyro's constant bias (deg/s), drawn once per episode from "
            "its seed")
    # -- obstacles ---------------------------------------------------------------------------
    n_obstacles: int = param(0, DESIGN, check=int_in_range(0, MAX_OBSTACLES),
                             doc="static obstacles")
    obstacle_kinds: tuple[str, ...] = param(
        ("box", "cylinder"), DESIGN, check=kinds_check,
        doc=f"kinds of the static obstacles, cycled: {', '.join(OBSTACLE_KINDS)}")
    obstacle_field: tuple[float, float, float] = param(
        (2.0, 8.0, 2.5), DESIGN, check=tuple_of(in_range(-MAX_DISTANCE, MAX_DISTANCE), 3),
        doc="static obstacles lie at x in [x0, x1], |y| <= half-width (m)")
    obstacle_ahead: float = param(0.0, DESIGN, check=in_range(0.0, MAX_DISTANCE),
                                  doc="put the first obstacle this far straight ahead (0: no)")
    obstacle_lane: float = param(
        0.0, "design: obstacles beside the path, never in it, for clips whose truth is 'no "
        "collision ahead'", check=in_range(0.0, MAX_DISTANCE),
        doc="keep every static obstacle's footprint at least this far (m) to one side of "
            "the line straight ahead of the start (y = 0); 0: anywhere in the field")
    wall_yaw: tuple[float, float] | None = param(
        None, "design: (-0.6, 0.6), walls mostly across the way ahead",
        check=optional(tuple_of(in_range(-math.pi, math.pi), 2)),
        doc="range of the seeded yaw of 'wall' obstacles (rad; 0: across the way, +-pi/2: "
            "along it)")
    arena_walls: bool = param(
        False, "design: the walled arena LGMD robots roam in, closed so that the robot "
        "keeps meeting obstacles", check=one_of(True, False),
        doc="four walls (0.5 m high, 0.2 m thick) on the rough patch's edges (arena, from 2 m "
            "behind the start), threats and collisions like obstacles")
    mover: str = param("none", DESIGN, check=one_of(*MOVERS),
                       doc=f"moving object: {', '.join(MOVERS)}")
    mover_distance: float = param(8.0, DESIGN, check=in_range(0.5, 200.0),
                                  doc="start distance of the moving object (m)")
    mover_speed: float = param(2.0, DESIGN, check=in_range(0.05, 50.0),
                               doc="approach speed of the moving object (m/s)")
    miss_distance: float = param(0.0, DESIGN, check=in_range(0.0, 100.0),
                                 doc="closest surface gap the mover is aimed at (0: collide)")
    mover_spread: float = param(15.0, DESIGN, check=in_range(0.0, 90.0),
                                doc="seeded spread of the mover's approach direction (deg)")
    aim_lead_speed: float = param(
        0.0, DESIGN, check=in_range(0.0, 50.0),
        doc="carrier speed (m/s) assumed when aiming the mover at a moving camera")
    scenery: int = param(16, DESIGN, check=int_in_range(0, MAX_SCENERY),
                         doc="background trees and buildings (not obstacles)")
    goal_distance: float = param(0.0, DESIGN, check=in_range(0.0, MAX_DISTANCE),
                                 doc="goal this far straight ahead (m); 0: no goal")
    goal_radius: float = param(0.5, DESIGN, check=positive, doc="goal reached within (m)")
    # -- lighting ----------------------------------------------------------------------------
    sun_elevation: float = param(50.0, DESIGN, check=in_range(5.0, 90.0),
                                 doc="sun elevation (degrees); its azimuth is seeded")
    shade: float = param(0.0, "the paper's road footage suffers illumination changes",
                         check=in_range(0.0, 1.0),
                         doc="fraction of sunlight a passing shade blocks (0: none)")
    flicker: float = param(0.0, "the paper's road footage suffers illumination changes",
                           check=in_range(0.0, 1.0), doc="relative amplitude of light flicker")
    flicker_hz: float = param(6.0, DESIGN, check=in_range(0.1, 100.0),
                              doc="flicker frequency (Hz)")

    def __post_init__(self) -> None:
        # one frame size, one value: "270x480" (the command line's spelling) is (270, 480);
        # a bad one is left for the check below to name
        with contextlib.suppress(ValueError):
            object.__setattr__(self, "resolution", parse_resolution(self.resolution))
        super().__post_init__()
        if self.shake_band[0] >= self.shake_band[1]:
            raise ValueError(f"parameter shake_band={self.shake_band!r}: low must be < high")
        nyquist = self.fps * self.substeps / 2
        if self.shake_band[1] >= nyquist:
            raise ValueError(f"parameter shake_band={self.shake_band!r}: must stay below "
                             f"{nyquist:g} Hz (half the physics rate)")
        x0, x1, half = self.obstacle_field
        if not (x0 < x1 and half > 0):
            raise ValueError(f"parameter obstacle_field={self.obstacle_field!r}: "
                             "needs x0 < x1 and half-width > 0")
        if self.wall_yaw is not None and self.wall_yaw[0] > self.wall_yaw[1]:
            raise ValueError(f"parameter wall_yaw={self.wall_yaw!r}: low must be <= high")
        if self.obstacle_lane >= half:
            raise ValueError(f"parameter obstacle_lane={self.obstacle_lane!r}: must be less "
                             f"than the obstacle_field half-width {half!r}")
        if self.obstacle_lane > 0 and self.obstacle_ahead > 0:
            raise ValueError(f"parameter obstacle_lane={self.obstacle_lane!r}: keeps obstacles "
                             f"out of the path, where obstacle_ahead={self.obstacle_ahead!r} "
                             "puts one; set one of them to 0")
        tiles = terrain.tile_grid(self.arena, self.terrain_cell)
        if self.resolved_roughness > 0 and tiles[0] * tiles[1] > MAX_TILES:
            raise ValueError(f"parameters arena={self.arena!r} / terrain_cell="
                             f"{self.terrain_cell!r}: {tiles[0] * tiles[1]} terrain tiles, more "
                             f"than {MAX_TILES}; use a coarser terrain_cell or a smaller arena")
        if self.arena_walls:
            self._check_inside_walls()

    def _check_inside_walls(self) -> None:
        """The start and the obstacle field must leave room inside the arena walls."""
        ax0, ax1, _ay0, ay1 = self.arena_bounds
        if ax1 <= WALL_GAP or ay1 <= WALL_GAP:
            raise ValueError(f"parameter arena_walls=True: arena={self.arena!r} puts a wall "
                             f"within {WALL_GAP} m of the start; lengthen or widen the arena")
        x0, x1, half = self.obstacle_field
        if (min(x1, ax1 - WALL_GAP) <= max(x0, ax0 + WALL_GAP)
                or min(half, ay1 - WALL_GAP) <= self.obstacle_lane):
            raise ValueError(f"parameter obstacle_field={self.obstacle_field!r}: no room inside "
                             f"the arena walls (x in [{ax0:g}, {ax1:g}], |y| <= {ay1:g}, "
                             f"less {WALL_GAP} m)")
        if self.obstacle_ahead > 0 and not (ax0 + WALL_GAP < self.obstacle_ahead
                                            < ax1 - WALL_GAP):
            raise ValueError(f"parameter obstacle_ahead={self.obstacle_ahead!r}: must stand "
                             f"inside the arena walls (x < {ax1 - WALL_GAP:g})")

    # -- derived -----------------------------------------------------------------------------

    @property
    def size(self) -> tuple[int, int]:
        """Frame (height, width)."""
        return frame_size(self.resolution)

    @property
    def arena_bounds(self) -> tuple[float, float, float, float]:
        """Extent (x0, x1, y0, y1) of the rough patch (m), where the arena walls stand:
        `arena` from ARENA_BACK behind the start, rounded up to whole terrain tiles as the
        terrain is; on flat ground `arena` as given."""
        length, width = self.arena
        if self.resolved_roughness > 0:
            tiles_y, tiles_x = terrain.tile_grid(self.arena, self.terrain_cell)
            tile = terrain.TILE_CELLS * self.terrain_cell
            length, width = tiles_x * tile, tiles_y * tile
        return -ARENA_BACK, length - ARENA_BACK, -width / 2, width / 2

    @property
    def resolved_wall_yaw(self) -> tuple[float, float]:
        """Range (rad) of the seeded yaw of wall obstacles."""
        return (-0.6, 0.6) if self.wall_yaw is None else self.wall_yaw

    @property
    def resolved_roughness(self) -> float:
        """Terrain RMS height (m)."""
        if self.roughness is not None:
            return float(self.roughness)
        return self.jitter * ROUGHNESS_PER_JITTER if self.carrier == "robot" else 0.0

    @property
    def resolved_shake(self) -> tuple[float, float]:
        """Shake RMS rotation (rad) and translation (m) of handheld and tripod carriers."""
        if self.carrier == "robot":
            return 0.0, 0.0
        degrees = self.shake if self.shake is not None else self.jitter * SHAKE_PER_JITTER
        scale = degrees / SHAKE_PER_JITTER  # translation follows rotation on the jitter scale
        # (degrees * pi) / 180, not math.radians: its degrees * (pi / 180) rounds otherwise
        return float(degrees) * math.pi / 180.0, scale * SHIFT_PER_JITTER

    @property
    def timestep(self) -> float:
        return 1.0 / (self.fps * self.substeps)
