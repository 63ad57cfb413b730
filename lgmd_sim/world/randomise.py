"""Per-episode randomisation: an episode's generator rewrites the compiled model in place.

Ground material and terrain heights, the sun and the passing shade, scenery, static
obstacles, the carrier's start (and its shake) and the moving object's size, colour and
launch. `JitterWorld.reset` calls these in a fixed order, and each draws from the one
generator in a fixed order: the same seed gives the same episode only as long as both
orders stay as they are.
"""

from __future__ import annotations

import colorsys
import math
from collections.abc import Callable

import numpy as np

from lgmd_sim.world import scene as scene_mod
from lgmd_sim.world import terrain
from lgmd_sim.world.carriers import HeldPath, Shake
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import WALL_GAP, SceneParams
from lgmd_sim.world.scene import Scene

#: Radius of the carrier's footprint (m) used to aim near misses: robot and camera rig.
CARRIER_RADIUS = {"robot": 0.17, "handheld": 0.035, "tripod": 0.035}
#: Places a static obstacle may try to stand clear of the others, the start and the goal.
PLACE_TRIES = 100

#: Terrain height (m) at world points (x, y) of the episode (`JitterWorld.ground_height`).
GroundHeight = Callable[[np.ndarray | float, np.ndarray | float], np.ndarray]
#: The seeded light of an episode: shade phase, period and width (s), flicker phase (rad).
LightEvents = tuple[float, float, float, float]


def seed_terrain(rng: np.random.Generator, m: mujoco.MjModel, sc: Scene,
                 p: SceneParams) -> np.ndarray | None:
    """Seed the ground material and, with rough terrain, write its heights into the
    physics heightfield and the drawn tiles; return the heights (m), None on flat ground.

    A renderer that already exists must be sent the tiles' heightfields again.
    """
    material = int(rng.integers(len(sc.ground_materials)))
    m.geom_matid[sc.ground_geom] = sc.ground_materials[material]
    if sc.hfield < 0:
        return None
    m.geom_matid[sc.tile_geoms.ravel()] = sc.terrain_materials[material]
    nrow, ncol = sc.terrain_shape
    heights = terrain.fractal_heights(rng, nrow, ncol, p.terrain_cell,
                                      p.resolved_roughness, p.terrain_scale)
    normalised = np.clip(heights / m.hfield_size[sc.hfield, 2], 0, 1)
    _write_hfield(m, sc.hfield, normalised)
    n = terrain.TILE_CELLS
    for (row, col), pair in zip(sc.tile_origin, sc.tile_hfields, strict=True):
        block = normalised[row:row + n + 1, col:col + n + 1]
        _write_hfield(m, pair[0], block)
        _write_hfield(m, pair[1], block[::terrain.COARSE_STEP, ::terrain.COARSE_STEP])
    return heights


def seed_light(rng: np.random.Generator, m: mujoco.MjModel, sc: Scene,
               p: SceneParams) -> LightEvents:
    """Seed the sun's azimuth; return the timing of the passing shade and the flicker."""
    az, el = rng.uniform(0, 2 * np.pi), math.radians(p.sun_elevation)
    m.light_dir[sc.sun] = [-math.cos(el) * math.cos(az),
                           -math.cos(el) * math.sin(az), -math.sin(el)]
    # Passing shade: one dip per period, at a seeded phase; flicker: a seeded phase.
    period, width = rng.uniform(4.0, 8.0), rng.uniform(1.0, 2.0)
    return rng.uniform(0, period), period, width, rng.uniform(0, 2 * np.pi)


def seed_scenery(rng: np.random.Generator, m: mujoco.MjModel, sc: Scene,
                 p: SceneParams) -> None:
    """Seed the distant trees and buildings: place, size, colour and turn."""
    cx = p.arena[0] / 2 - scene_mod.ARENA_BACK
    for i, (body, geoms) in enumerate(sc.scenery):
        r, a = rng.uniform(14.0, 45.0), rng.uniform(0, 2 * np.pi)
        x, y = cx + r * math.cos(a), r * math.sin(a)
        if i % 3 != 2:  # tree: trunk and crown
            h, crown = rng.uniform(2.0, 5.0), rng.uniform(1.0, 2.5)
            _set_size(m, geoms[0], [rng.uniform(0.1, 0.25), h / 2])
            m.geom_pos[geoms[0]] = [0, 0, h / 2]
            _set_size(m, geoms[1], [crown, crown, rng.uniform(1.2, 1.8) * crown])
            m.geom_pos[geoms[1]] = [0, 0, h + 0.8 * crown]
            m.geom_rgba[geoms[1]] = [*_colour(rng, (0.2, 0.4), (0.3, 0.7), (0.3, 0.6)), 1]
        else:  # building: block and roof
            hx, hy, hz = rng.uniform(2, 6), rng.uniform(2, 6), rng.uniform(2, 6)
            _set_size(m, geoms[0], [hx, hy, hz])
            m.geom_pos[geoms[0]] = [0, 0, hz]
            _set_size(m, geoms[1], [hx * 1.05, hy * 1.05, 0.3])
            m.geom_pos[geoms[1]] = [0, 0, 2 * hz + 0.3]
            m.geom_rgba[geoms[0]] = [*_colour(rng, (0, 1), (0.05, 0.3), (0.6, 0.95)), 1]
            m.geom_rgba[geoms[1]] = [*_colour(rng, (0, 0.1), (0.3, 0.6), (0.3, 0.5)), 1]
        m.body_pos[body] = [x, y, 0]
        m.body_quat[body] = _yaw_quat(rng.uniform(0, 2 * np.pi))


def seed_obstacles(rng: np.random.Generator, m: mujoco.MjModel, sc: Scene, p: SceneParams,
                   ground: GroundHeight) -> None:
    """Seed the static obstacles' shapes and place them on the ground, apart from each
    other, the start and the goal as far as PLACE_TRIES tries allow; inside the arena
    walls and out of the obstacle lane always (ValueError where no try is)."""
    placed: list[tuple[float, float, float]] = []
    for i, (body, kind, geoms) in enumerate(sc.obstacles):
        radius = _shape_obstacle(rng, m, sc, p, kind, geoms)
        if i == 0 and p.obstacle_ahead > 0:
            x, y = p.obstacle_ahead, 0.0
            yaw = _obstacle_yaw(rng, p, kind, x, y)
        else:
            x, y, yaw = _place_obstacle(rng, m, p, i, kind, geoms, radius, placed)
        placed.append((x, y, radius))
        # Sink obstacles a little so they meet sloped ground without gaps.
        m.body_pos[body] = [x, y, float(ground(x, y)) - 0.03]
        m.body_quat[body] = _yaw_quat(yaw)
        _refresh_bvh(m, body)


def _place_obstacle(rng: np.random.Generator, m: mujoco.MjModel, p: SceneParams, index: int,
                    kind: str, geoms: list[int], radius: float,
                    placed: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    """Draw an obstacle's place (x, y) and yaw: the first try clear of the others (by
    0.6 m between their footprint circles), the start (1.2 m) and the goal (0.5 m); else
    the last one tried, or, inside walls or beside a lane, the least crowded one."""
    x0, x1, half = p.obstacle_field
    y0, y1 = -half, half
    if p.arena_walls:  # tries only where the centre may stand (SceneParams checks there is room)
        ax0, ax1, ay0, ay1 = p.arena_bounds
        x0, x1 = max(x0, ax0 + WALL_GAP), min(x1, ax1 - WALL_GAP)
        y0, y1 = max(y0, ay0 + WALL_GAP), min(y1, ay1 - WALL_GAP)
    # The walls and the lane bound the whole footprint, which turns with the yaw: then
    # each try draws its yaw. Otherwise the yaw is drawn once placed, as it always was,
    # so that seeds give the worlds they gave before the walls and the lane.
    bounded = p.arena_walls or p.obstacle_lane > 0
    chosen: tuple[float, float, float | None] | None = None
    most = -math.inf
    for _ in range(PLACE_TRIES):
        x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
        yaw = _obstacle_yaw(rng, p, kind, x, y) if bounded else None
        if yaw is not None and not _within_bounds(m, p, geoms, x, y, yaw):
            continue
        # the least of the gaps beyond those wanted: clear where positive
        slack = min([math.hypot(x, y) - radius - 1.2]
                    + [math.hypot(x - a, y - b) - radius - r - 0.6 for a, b, r in placed])
        if p.goal_distance > 0:
            slack = min(slack, math.hypot(x - p.goal_distance, y) - radius - p.goal_radius - 0.5)
        if not bounded or slack > most:
            chosen, most = (x, y, yaw), slack
        if slack > 0:
            break
    if chosen is None:
        where = " inside the arena walls" if p.arena_walls else ""
        if p.obstacle_lane > 0:
            where += f" {p.obstacle_lane:g} m off the path (obstacle_lane)"
        raise ValueError(f"obstacle {index} ({kind}) found no place in obstacle_field="
                         f"{p.obstacle_field!r}{where} in {PLACE_TRIES} tries; widen the "
                         "field or narrow obstacle_lane")
    x, y, yaw = chosen
    return x, y, _obstacle_yaw(rng, p, kind, x, y) if yaw is None else yaw


def _obstacle_yaw(rng: np.random.Generator, p: SceneParams, kind: str, x: float,
                  y: float) -> float:
    if kind == "balloon":  # the pole to one side, seen from the start
        return math.atan2(y, x) + rng.choice([0.0, np.pi]) + rng.uniform(-0.4, 0.4)
    if kind == "wall":
        return rng.uniform(*p.resolved_wall_yaw)
    return rng.uniform(0, 2 * np.pi)


def _within_bounds(m: mujoco.MjModel, p: SceneParams, geoms: list[int], x: float, y: float,
                   yaw: float) -> bool:
    """Whether an obstacle at (x, y, yaw) keeps its whole footprint (every solid geom:
    box corners, round geoms' radii) WALL_GAP inside the arena walls and out of the lane."""
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    points = []
    for g in geoms:
        if not m.geom_contype[g]:
            continue
        centre = rot @ m.geom_pos[g, :2] + (x, y)
        size = m.geom_size[g]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * size[:2]
            points.append(corners @ rot.T + centre)
        else:  # cylinders, spheres, ellipsoids: round in the ground plane
            points.append(centre + np.array([[-1, -1], [1, 1]]) * size[0])
    xy = np.concatenate(points)
    (lo_x, lo_y), (hi_x, hi_y) = xy.min(0), xy.max(0)
    lane = p.obstacle_lane
    if lane > 0 and not (lo_y >= lane or hi_y <= -lane):
        return False
    if p.arena_walls:
        ax0, ax1, ay0, ay1 = p.arena_bounds
        return (lo_x >= ax0 + WALL_GAP and hi_x <= ax1 - WALL_GAP
                and lo_y >= ay0 + WALL_GAP and hi_y <= ay1 - WALL_GAP)
    return True


def place_carrier(rng: np.random.Generator, m: mujoco.MjModel, d: mujoco.MjData, sc: Scene,
                  p: SceneParams, ground: GroundHeight) -> HeldPath | None:
    """Put the carrier at the start: the robot just above the ground under it, a camera
    rig at the start of its seeded path, which is returned (None for the robot)."""
    q = sc.carrier_qpos_adr
    if sc.wheel_actuators.size:
        xs, ys = np.meshgrid([-0.17, 0.0, 0.17], [-0.14, 0.0, 0.14])
        d.qpos[q:q + 3] = [0, 0, float(ground(xs, ys).max()) + 0.1]
        d.qpos[q + 3:q + 7] = [1, 0, 0, 0]
        return None
    angle, shift = p.resolved_shake
    held = HeldPath(p, Shake(rng, angle, shift, p.shake_band), m.opt.timestep)
    pos, quat = held.start_pose()
    d.mocap_pos[sc.mocap], d.mocap_quat[sc.mocap] = pos, quat
    d.qpos[q:q + 3], d.qpos[q + 3:q + 7] = pos, quat
    return held


def launch_mover(rng: np.random.Generator, m: mujoco.MjModel, d: mujoco.MjData, sc: Scene,
                 p: SceneParams, heights: np.ndarray | None) -> None:
    """Seed the moving object and send it at (or, with miss_distance, past) the camera.

    The camera's pose is read from `d`: call it once the carrier has settled.
    """
    if sc.mover_body < 0:
        return
    _launch(rng, m, d, sc, p, heights)
    for body in (sc.mover_body, sc.mover_pivot):
        if body >= 0:  # resized and moved: its collision bounds follow
            _refresh_bvh(m, body)


def _launch(rng: np.random.Generator, m: mujoco.MjModel, d: mujoco.MjData, sc: Scene,
            p: SceneParams, heights: np.ndarray | None) -> None:
    mujoco.mj_forward(m, d)
    cam = d.cam_xpos[sc.camera].copy()
    heading = np.array([1.0, 0.0, 0.0])
    spread = math.radians(p.mover_spread)
    phi = rng.uniform(-spread, spread)
    away = np.array([math.cos(phi), math.sin(phi), 0.0])  # from the target to the start
    side = np.array([-away[1], away[0], 0.0]) * rng.choice([-1.0, 1.0])
    geoms = sc.mover_geoms
    kind = sc.mover_kind
    if kind == "vehicle":
        length, width = rng.uniform(3.6, 4.6), rng.uniform(1.6, 1.9)
        _shape_vehicle(rng, m, geoms, length, width)
        half_side = width / 2
    else:
        r = rng.uniform(0.15, 0.25) if kind != "ball" else rng.uniform(0.1, 0.14)
        _set_size(m, geoms[0], [r, 0, 0])
        mass = m.body_mass[sc.mover_body]
        m.body_inertia[sc.mover_body] = 0.4 * mass * r * r
        sat = (0.7, 0.95) if kind != "ball" else (0.0, 0.2)
        m.geom_rgba[geoms[0]] = [*_colour(rng, (0, 1), sat, (0.6, 0.95)), 1]
        half_side = r
    gap = p.miss_distance + half_side + CARRIER_RADIUS[p.carrier] if p.miss_distance > 0 else 0
    if kind == "swing":
        _launch_swing(rng, m, d, sc, p, cam, away, side * gap)
        return
    travel = p.mover_distance / p.mover_speed
    target = cam + heading * p.aim_lead_speed * travel + side * gap
    start = target + away * p.mover_distance
    qa, da = sc.mover_qpos_adr, sc.mover_dof_adr
    if kind == "vehicle":
        ground = float(heights.max()) if heights is not None else 0.0
        m.body_pos[sc.mover_body] = [start[0], start[1], ground]  # clears every bump
        m.body_quat[sc.mover_body] = _yaw_quat(phi + math.pi)
        d.qpos[qa], d.qvel[da] = 0.0, p.mover_speed
        return
    if kind == "balloon":
        start[2] = target[2]
        velocity = (target - start) / travel  # gravity compensated: a straight drift
    else:  # a thrown ball: a ballistic arc from hand height through the target
        start[2] = max(target[2], 0.3) + rng.uniform(0.2, 0.8)
        velocity = (target - start) / travel - 0.5 * m.opt.gravity * travel
    d.qpos[qa:qa + 3] = start
    d.qpos[qa + 3:qa + 7] = [1, 0, 0, 0]
    d.qvel[da:da + 3] = velocity
    d.qvel[da + 3:da + 6] = rng.normal(0, 0.5, 3)  # a little spin


def _launch_swing(rng: np.random.Generator, m: mujoco.MjModel, d: mujoco.MjData, sc: Scene,
                  p: SceneParams, cam: np.ndarray, away: np.ndarray, miss: np.ndarray) -> None:
    """A ball on a rope from a gallows pole: released in front, its lowest point at
    the camera (plus the miss offset)."""
    length = rng.uniform(2.0, 3.0)
    bottom = cam + miss
    pivot = bottom + np.array([0, 0, length])
    yaw = math.atan2(away[1], away[0])
    m.body_pos[sc.mover_pivot] = pivot
    m.body_quat[sc.mover_pivot] = _yaw_quat(yaw)
    pole, arm = _body_geoms_of(m, sc.mover_pivot)
    offset = 0.9  # pole beside the swing plane
    _set_size(m, pole, [0.04, pivot[2] / 2 + 0.1])
    m.geom_pos[pole] = [0, offset, -pivot[2] / 2 + 0.1]
    _set_size(m, arm, [0.03, offset / 2, 0.03])
    m.geom_pos[arm] = [0, offset / 2, 0.1]
    m.body_pos[sc.mover_body] = [0, 0, -length]
    joint = m.body_jntadr[sc.mover_body]
    m.jnt_pos[joint] = [0, 0, length]
    string = sc.mover_geoms[1]
    r = m.geom_size[sc.mover_geoms[0], 0]
    _set_size(m, string, [0.006, (length - r) / 2])
    m.geom_pos[string] = [0, 0, (length + r) / 2]
    release = math.asin(min(p.mover_distance / length, 0.9))
    d.qpos[sc.mover_qpos_adr] = -release  # the ball starts out in front (local +x)
    d.qvel[sc.mover_dof_adr] = 0.0


def _shape_obstacle(rng: np.random.Generator, m: mujoco.MjModel, sc: Scene, p: SceneParams,
                    kind: str, geoms: list[int]) -> float:
    """Seed size, colour and texture of one static obstacle; return its footprint radius."""
    main = geoms[0]
    if kind == "balloon":
        return _shape_hanging_balloon(rng, m, p, geoms)
    if kind == "box":
        size = [rng.uniform(0.15, 0.5), rng.uniform(0.15, 0.5), rng.uniform(0.15, 0.6)]
    elif kind == "cylinder":
        size = [rng.uniform(0.08, 0.3), rng.uniform(0.2, 0.8), 0.0]
    else:  # wall
        size = [rng.uniform(0.06, 0.12), rng.uniform(0.8, 2.0), rng.uniform(0.25, 0.7)]
    _set_size(m, main, size)
    top = size[2] if kind != "cylinder" else size[1]
    m.geom_pos[main] = [0, 0, top]
    materials = (-1, *sc.obstacle_materials)
    m.geom_matid[main] = materials[int(rng.integers(len(materials)))]
    m.geom_rgba[main] = [*_colour(rng, (0, 1), (0.3, 0.9), (0.35, 0.9)), 1]
    return float(math.hypot(size[0], size[1]) if kind != "cylinder" else size[0])


def _shape_hanging_balloon(rng: np.random.Generator, m: mujoco.MjModel, p: SceneParams,
                           geoms: list[int]) -> float:
    """A balloon hanging on a string from an arm on a wooden pole (Sec. 4.1.2 b)."""
    balloon, pole, arm, string = geoms
    r = rng.uniform(0.15, 0.25)
    if p.carrier == "robot":
        centre = r + rng.uniform(0.02, 0.25)
    else:
        centre = p.camera_height + rng.uniform(-0.12, 0.12)
    offset = r + rng.uniform(0.35, 0.6)  # pole to one side (local +y)
    top = centre + 1.15 * r + rng.uniform(0.4, 0.8)
    _set_size(m, balloon, [r, r, 1.15 * r])
    m.geom_pos[balloon] = [0, 0, centre]
    m.geom_rgba[balloon] = [*_colour(rng, (0, 1), (0.7, 0.95), (0.6, 0.95)), 1]
    _set_size(m, pole, [0.025, top / 2])
    m.geom_pos[pole] = [0, offset, top / 2]
    _set_size(m, arm, [0.015, offset / 2, 0.015])
    m.geom_pos[arm] = [0, offset / 2, top]
    length = top - centre - 1.15 * r
    _set_size(m, string, [0.003, length / 2])
    m.geom_pos[string] = [0, 0, top - length / 2]
    return r + 0.05


def _shape_vehicle(rng: np.random.Generator, m: mujoco.MjModel, geoms: list[int],
                   length: float, width: float) -> None:
    """Size the car's body, cabin and wheels to its seeded length and width; colour it."""
    main, cabin, *wheels = geoms
    _set_size(m, main, [length / 2, width / 2, 0.35])
    m.geom_pos[main] = [0, 0, 0.45]
    m.geom_rgba[main] = [*_colour(rng, (0, 1), (0.4, 0.9), (0.4, 0.9)), 1]
    _set_size(m, cabin, [length * 0.27, width * 0.45, 0.28])
    m.geom_pos[cabin] = [-0.05 * length, 0, 1.08]
    for k, w in enumerate(wheels):
        _set_size(m, w, [0.3, 0.1, 0])
        m.geom_pos[w] = [(0.32 if k < 2 else -0.32) * length,
                         (1 if k % 2 else -1) * (width / 2 - 0.05), 0.3]


# --- model rewriting helpers ------------------------------------------------------------


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def _colour(rng: np.random.Generator, hue: tuple[float, float], sat: tuple[float, float],
            val: tuple[float, float]) -> tuple[float, float, float]:
    return colorsys.hsv_to_rgb(rng.uniform(*hue), rng.uniform(*sat), rng.uniform(*val))


def _body_geoms_of(m: mujoco.MjModel, body: int) -> list[int]:
    start, count = m.body_geomadr[body], m.body_geomnum[body]
    return list(range(start, start + count))


def _write_hfield(m: mujoco.MjModel, hfield: int, heights: np.ndarray) -> None:
    """Write normalised heights (rows along +y) into a heightfield of the model."""
    adr = m.hfield_adr[hfield]
    m.hfield_data[adr:adr + heights.size] = heights.ravel()


def _refresh_bvh(m: mujoco.MjModel, body: int) -> None:
    """Recompute a body's bounding-volume hierarchy after its geoms moved or resized.

    MuJoCo's broad and mid phase test these boxes (compiled once, in the body's inertial
    frame) before any exact collision test: stale boxes silently lose contacts.
    """
    adr, num = m.body_bvhadr[body], m.body_bvhnum[body]
    if num <= 0:
        return
    inertial = np.empty(9)
    mujoco.mju_quat2Mat(inertial, m.body_iquat[body])
    inertial = inertial.reshape(3, 3)
    rot = np.empty(9)
    lo = np.empty((num, 3))
    hi = np.empty((num, 3))
    for k in range(num - 1, -1, -1):  # children come after their parent
        node = adr + k
        geom = m.bvh_nodeid[node]
        if geom >= 0:
            mujoco.mju_quat2Mat(rot, m.geom_quat[geom])
            r = inertial.T @ rot.reshape(3, 3)
            centre = inertial.T @ (m.geom_pos[geom] - m.body_ipos[body]) + r @ m.geom_aabb[geom, :3]
            half = np.abs(r) @ m.geom_aabb[geom, 3:]
            lo[k], hi[k] = centre - half, centre + half
        else:
            a, b = m.bvh_child[node]
            lo[k], hi[k] = np.minimum(lo[a], lo[b]), np.maximum(hi[a], hi[b])
        m.bvh_aabb[node] = [*(lo[k] + hi[k]) / 2, *(hi[k] - lo[k]) / 2]


def _set_size(m: mujoco.MjModel, geom: int, size: list[float]) -> None:
    """Resize a primitive geom, keeping its bounding sphere and box (used by the
    collision broad phase) consistent."""
    sx, sy, sz = [*size, 0.0, 0.0][:3]
    G = mujoco.mjtGeom
    t = m.geom_type[geom]
    if t == G.mjGEOM_SPHERE:
        half, rbound = [sx, sx, sx], sx
    elif t == G.mjGEOM_CYLINDER:
        half, rbound = [sx, sx, sy], math.hypot(sx, sy)
    elif t == G.mjGEOM_CAPSULE:
        half, rbound = [sx, sx, sx + sy], sx + sy
    elif t == G.mjGEOM_ELLIPSOID:
        half, rbound = [sx, sy, sz], max(sx, sy, sz)
    else:  # box
        half, rbound = [sx, sy, sz], math.sqrt(sx * sx + sy * sy + sz * sz)
    m.geom_size[geom] = [sx, sy, sz]
    m.geom_aabb[geom] = [0, 0, 0, *half]
    m.geom_rbound[geom] = rbound
