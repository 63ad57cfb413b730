"""The ViewOracle and what the camera sees of the threats (`lgmd_sim.world.view`):
obstacles placed by hand around the camera of a small world, seen or not as they stand in
or out of its field of view, in front of or behind it, in the open or hidden behind
another; the view threat among those seen; the controller's episodes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim.controllers import make, rollout
from lgmd_sim.controllers.avoid import OracleParams
from lgmd_sim.envs.zone import in_trigger_zone
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.pieces import HIDDEN
from lgmd_sim.world.view import CameraView

# RoughTerrainObstacles' obstacles by kind (its obstacle_kinds, cycled)
BOX, CYLINDER, WALL = 0, 1, 2


def small_world(scenario: str):
    """A world of `scenario` at 64 x 64 (its field of view 55 degrees either way), reset,
    no frames rendered, and its env (to close)."""
    env = gym.make(f"lgmd_sim/{scenario}-v0", resolution="small", frame="none")
    env.reset(seed=3)
    return env.unwrapped.world, env


@pytest.fixture(scope="module")
def world():
    world, env = small_world("RoughTerrainObstacles")
    yield world
    env.close()


def heading(world) -> float:
    forward = -world.data.cam_xmat[world.scene.camera].reshape(3, 3)[:, 2]
    return math.atan2(forward[1], forward[0])


def place(world, i: int, ahead: float, left: float = 0.0, *, yaw: float = 0.0,
          top: float | None = None) -> None:
    """Stand obstacle i `ahead` and to the `left` of the camera (m), turned by `yaw` from
    across the camera's heading: on the ground (sunk 3 cm, as seeded), or with its top at
    height `top`."""
    m, d = world.model, world.data
    h = heading(world)
    cam = d.cam_xpos[world.scene.camera]
    x = cam[0] + ahead * math.cos(h) - left * math.sin(h)
    y = cam[1] + ahead * math.sin(h) + left * math.cos(h)
    body, _kind, geoms = world.scene.obstacles[i]
    z = float(world.ground_height(x, y)) - 0.03
    if top is not None:  # the main geom's top above its body's origin: its offset and half height
        z = top - m.geom_pos[geoms[0], 2] - m.geom_aabb[geoms[0], 5]
    m.body_pos[body] = [x, y, z]
    m.body_quat[body] = [math.cos((h + yaw) / 2), 0.0, 0.0, math.sin((h + yaw) / 2)]
    mujoco.mj_forward(m, d)


def clear(world) -> None:
    """Every obstacle behind the camera, out of its view."""
    for i in range(len(world.scene.obstacles)):
        place(world, i, ahead=-1.5, left=1.2 * i - 3.0)


def test_an_obstacle_is_seen_in_front_of_the_camera_within_its_field_of_view(world):
    view = CameraView(world)
    clear(world)
    assert view.seen() == frozenset()
    place(world, BOX, ahead=2.0)
    assert view.seen() == {BOX}
    place(world, BOX, ahead=-2.0)  # behind the camera
    assert view.seen() == frozenset()
    beside = math.radians(75)  # beyond half the field of view, box and all
    place(world, BOX, ahead=2.5 * math.cos(beside), left=2.5 * math.sin(beside))
    assert view.seen() == frozenset()


def test_an_obstacle_hidden_behind_another_is_not_seen(world):
    """A cylinder behind a wall across the way, its top below the wall's: hidden, though
    in the field of view (seen with the wall gone)."""
    view = CameraView(world)
    clear(world)
    place(world, WALL, ahead=1.0)
    wall = world.scene.obstacles[WALL][2][0]
    wall_top = world.data.geom_xpos[wall, 2] + world.model.geom_aabb[wall, 5]
    place(world, CYLINDER, ahead=1.6, top=wall_top - 0.05)
    assert view.seen() == {WALL}
    place(world, WALL, ahead=-2.0)
    assert view.seen() == {CYLINDER}


def test_a_long_wall_is_seen_where_only_its_end_is_in_view(world):
    """A 'wall' obstacle along the heading beside the robot: its centre and its point
    nearest the robot are out of view, its far end in view; the grid of rays sees it."""
    view = CameraView(world)
    clear(world)
    place(world, WALL, ahead=0.0, left=0.4, yaw=math.pi / 2)
    wall = world.scene.obstacles[WALL][2][0]
    to_centre = world.data.geom_xpos[wall] - world.data.cam_xpos[world.scene.camera]
    bearing = math.atan2(to_centre[1], to_centre[0]) - heading(world)
    assert abs(bearing) > math.radians(55 / 2)  # its centre is out of view
    assert view.seen() == {WALL}


def test_the_drawn_terrain_does_not_change_what_is_seen(world):
    """The renderer moves terrain tiles between groups 0 and HIDDEN by level of detail:
    what is seen is the same either way, and the tiles keep their groups."""
    view = CameraView(world)
    clear(world)
    place(world, BOX, ahead=2.0)
    place(world, CYLINDER, ahead=1.5, left=1.5)
    tiles = world.scene.tile_geoms
    assert tiles.size
    groups = world.model.geom_group
    groups[tiles] = HIDDEN
    hidden = view.seen()
    groups[tiles[::2, 0]] = 0
    drawn = groups[tiles].copy()
    assert view.seen() == hidden
    assert np.array_equal(groups[tiles], drawn)


def test_an_arena_wall_is_seen_through_its_drawn_face():
    """An arena wall is drawn as a plane in front of its box: a ray meets the plane first,
    and the wall is seen."""
    world, env = small_world("ArenaRoam")
    try:
        clear(world)
        front = world.params.n_obstacles  # the walls follow the obstacles: front first
        assert CameraView(world).seen() == {front}
    finally:
        env.close()


@pytest.fixture(scope="module")
def viewed():
    """A small RoughTerrainObstacles env as the ViewOracle observes it (view keys in info),
    reset and driven a few frames, so that the robot closes on what is ahead."""
    env = make("view-oracle").wrap_env(gym.make("lgmd_sim/RoughTerrainObstacles-v0",
                                                resolution="small", frame="none"))
    env.reset(seed=3)
    for _ in range(10):
        env.step(np.array([0.6, 0.0]))
    yield env
    env.close()


def step_with(env, **placed: tuple[float, float]) -> dict:
    """The info of one more frame at cruise, with every obstacle cleared but those in
    `placed` (kind name: (ahead, left) of the camera)."""
    world = env.unwrapped.world
    clear(world)
    for kind, (ahead, left) in placed.items():
        place(world, {"box": BOX, "cylinder": CYLINDER, "wall": WALL}[kind], ahead, left)
    return env.step(np.array([0.6, 0.0]))[-1]


def test_an_obstacle_ahead_in_view_is_the_view_threat_with_the_worlds_ttc(viewed):
    info = step_with(viewed, box=(1.0, 0.0))
    assert info["threat_index"] == info["view_threat_index"] == BOX
    assert math.isfinite(info["threat_ttc"])
    for key in ("ttc", "distance", "bearing", "closing_speed"):
        assert info[f"view_threat_{key}"] == info[f"threat_{key}"], key


@pytest.mark.parametrize("ahead, left", [(-1.0, 0.0), (0.5, 1.5)], ids=["behind", "beside"])
def test_an_obstacle_out_of_view_is_no_view_threat(viewed, ahead, left):
    """Every obstacle out of view (the box behind or beside the camera, the others behind):
    the world's threat is one of them, the view has none."""
    info = step_with(viewed, box=(ahead, left))
    assert info["threat_index"] >= 0
    assert info["view_threat_index"] == -1 and info["view_threat_ttc"] == math.inf


def test_view_oracle_avoids_where_the_oracle_would():
    """An episode of RoughTerrainObstacles: the ViewOracle triggers on what it sees only,
    on frames where the Oracle triggers too, and drives to the goal."""
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", frame="none")
    controller = make("view-oracle")
    try:
        steps = list(rollout(controller.wrap_env(env), controller, seed=20000))
    finally:
        env.close()
    zone = OracleParams()
    view_zone = [in_trigger_zone({k: s.info[f"view_{k}"] for k in
                                  ("threat_ttc", "threat_distance", "threat_bearing")}, zone)
                 for s in steps]
    oracle_zone = [in_trigger_zone(s.info, zone) for s in steps]
    assert any(v and o for v, o in zip(view_zone, oracle_zone, strict=True))
    last = steps[-1].info
    assert last["goal_reached"] and last["first_collision_frame"] < 0


def test_view_oracle_is_deterministic():
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", frame="none",
                   time_limit=4.0)
    controller = make("view-oracle")
    try:
        runs = [[(s.action, s.info["view_threat_index"], s.info["view_threat_ttc"])
                 for s in rollout(controller.wrap_env(env), controller, seed=20001)]
                for _ in range(2)]
    finally:
        env.close()
    assert len(runs[0]) == len(runs[1]) > 100
    for (a, i, t), (b, j, u) in zip(*runs, strict=True):
        assert (a is None and b is None) or np.array_equal(a, b)
        assert i == j and t == u
