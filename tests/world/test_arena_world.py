"""The arena task's world: walls around the rough patch, obstacles beside the path
(obstacle_lane), the yaw of wall obstacles (wall_yaw) and the ArenaRoam scenario."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401 - registers the scenarios
from lgmd_sim.envs.catalogue import params_for
from lgmd_sim.world import JitterWorld, SceneParams
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import WALL_GAP
from lgmd_sim.world.pieces import WALLS

TINY = (16, 16)  # frames are not looked at here: the smallest the SSIM allows


def world_for(**changes) -> JitterWorld:
    changes = {"resolution": TINY, "scenery": 0, **changes}
    return JitterWorld(SceneParams(**changes))


def corners(footprint: dict) -> np.ndarray:
    """The (x, y) extreme points of a top-view footprint (polygon corners, circle box)."""
    if "polygon" in footprint:
        return np.array(footprint["polygon"])
    x, y, r = footprint["circle"]
    return np.array([[x - r, y - r], [x + r, y + r]])


def solid_extent(world: JitterWorld, geoms: list[int]) -> np.ndarray:
    """(x, y) extreme points of an obstacle's solid geoms seen from above: box corners,
    the bounding squares of round geoms (a balloon's pole included)."""
    m, d = world.model, world.data
    points = []
    for g in geoms:
        if not m.geom_contype[g]:
            continue
        size, centre = m.geom_size[g], d.geom_xpos[g, :2]
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            rot = d.geom_xmat[g].reshape(3, 3)[:2, :2]
            points.append(np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * size[:2] @ rot.T
                          + centre)
        else:
            points.append(centre + np.array([[-1, -1], [1, 1]]) * size[0])
    return np.concatenate(points)


def yaw_of(world: JitterWorld, body: int) -> float:
    w, _x, _y, z = world.model.body_quat[body]
    return math.atan2(2 * w * z, 1 - 2 * z * z)


# -- walls ---------------------------------------------------------------------------------


@pytest.mark.parametrize("jitter, bounds", [
    (1.0, (-2.0, 6.0, -4.0, 4.0)),  # rough: rounded up to whole 2 m tiles
    (0.0, (-2.0, 5.0, -3.5, 3.5)),  # flat: the arena as given
])
def test_walls_stand_at_the_rough_patch_edges(jitter, bounds):
    params = SceneParams(arena=(7.0, 7.0), arena_walls=True, jitter=jitter, resolution=TINY)
    assert params.arena_bounds == pytest.approx(bounds)
    world = JitterWorld(params)
    world.reset(seed=0)
    view = world.top_view()["obstacles"]
    assert len(view) == len(WALLS) == 4
    x0, x1, y0, y1 = bounds
    front, back, left, right = (corners(f) for f in view)
    assert front[:, 0].min() == pytest.approx(x1) and back[:, 0].max() == pytest.approx(x0)
    assert left[:, 1].min() == pytest.approx(y1) and right[:, 1].max() == pytest.approx(y0)
    # closed corners: the front and back walls span the side walls' ends
    assert front[:, 1].min() < y0 and front[:, 1].max() > y1
    assert world.scene.n_threats == 4 and not world.truth["collision"]
    world.close()
    plain = JitterWorld(SceneParams(arena=(7.0, 7.0), resolution=TINY))
    plain.reset(seed=0)
    assert plain.top_view()["obstacles"] == [] and plain.scene.n_threats == 0
    plain.close()


def test_driving_at_the_front_wall_collides_and_the_episode_goes_on():
    env = gym.make("lgmd_sim/ArenaRoam-v0", resolution=TINY, n_obstacles=0, scenery=0,
                   arena=[4.0, 4.0])  # the front wall 2 m ahead
    _obs, info = env.reset(seed=0)
    front = env.unwrapped.world.scene.n_threats - len(WALLS)  # walls follow the obstacles
    assert info["threat_index"] == front or info["threat_ttc"] == math.inf
    truths, hit = [], None
    for frame in range(1, 120):
        _obs, _r, terminated, truncated, info = env.step(np.array([1.0, 0.0], np.float32))
        assert not terminated and not truncated
        if info["collision"]:
            hit = frame
            break
        assert info["threat_index"] == front
        truths.append(info)
    assert hit is not None and 40 < hit < 90  # about 1.7 m at up to 1 m/s
    assert np.all(np.diff([t["threat_distance"] for t in truths]) < 0)
    for t in truths[10:]:  # under way: the time to collision counts down to the hit
        assert t["threat_ttc"] == pytest.approx((hit - t["frame_index"]) / 30, abs=0.4)
    assert info["first_collision_frame"] == hit and info["threat_index"] == front
    x1 = env.unwrapped.params.arena_bounds[1]
    for _ in range(45):  # keeps pushing at full speed: stopped by the wall, not through it
        _obs, _r, terminated, truncated, info = env.step(np.array([1.0, 0.0], np.float32))
        assert not terminated and not truncated
    assert info["first_collision_frame"] == hit and info["collision"]
    assert info["carrier_pos"][0] < x1 - 0.1
    env.close()


def test_nearest_threat_is_a_wall_where_an_obstacle_bounding_sphere_is_nearer():
    # A tall cylinder ahead: its bounding sphere comes nearer than its surface, and nearer
    # than the side walls' surfaces, which are nearest of all.
    world = world_for(carrier="robot", jitter=0.0, arena=(10.0, 1.4), arena_walls=True,
                      n_obstacles=1, obstacle_kinds=("cylinder",), obstacle_ahead=1.3)
    world.reset(seed=28)  # a cylinder 1.54 m tall
    m, d, sc = world.model, world.data, world.scene
    fromto = np.zeros(6)

    def exact(geom: int) -> float:
        return mujoco.mj_geomDistance(m, d, sc.carrier_main_geom, geom, 100.0, fromto)

    cylinder = sc.obstacles[0][2][0]
    sphere_gap = (np.linalg.norm(d.geom_xpos[cylinder] - d.cam_xpos[sc.camera])
                  - m.geom_rbound[cylinder])
    wall_gaps = [exact(g) for g in sc.wall_geoms]
    assert sphere_gap < min(wall_gaps) < exact(cylinder)  # the case this test is about
    truth = world.truth
    assert truth["threat_index"] in (1 + WALLS.index("left"), 1 + WALLS.index("right"))
    assert truth["threat_distance"] == pytest.approx(min(wall_gaps), abs=1e-9)
    assert truth["threat_distance"] == pytest.approx(0.6, abs=0.02)  # 0.7 m less the chassis
    world.close()


def test_an_obstacle_nearer_than_every_wall_is_the_threat():
    # A long wall's bounding sphere reaches past the robot: ranked with the obstacles by
    # it, the walls would crowd the obstacle out of the exact candidates.
    world = world_for(carrier="robot", jitter=0.0, arena=(10.0, 8.0), arena_walls=True,
                      n_obstacles=2, obstacle_kinds=("cylinder",), obstacle_ahead=1.0,
                      obstacle_field=(3.0, 7.0, 3.0))
    for seed in range(3):
        world.reset(seed=seed)
        assert world.truth["threat_index"] == 0, seed
        assert world.truth["threat_distance"] < 0.85
    world.close()


@pytest.mark.parametrize("yaw", [0.0, 0.8, 1.2])
def test_a_touched_obstacle_stays_the_threat_while_walls_close_in(yaw):
    # Pressed against a wall obstacle at an angle, the robot closes on it no more (its
    # nearest point lies beside the camera) while it still closes on some arena wall.
    world = world_for(carrier="robot", jitter=0.0, arena=(8.0, 8.0), arena_walls=True,
                      n_obstacles=1, obstacle_kinds=("wall",), obstacle_ahead=1.2,
                      wall_yaw=(yaw, yaw))
    world.reset(seed=0)
    touching = 0
    for _ in range(75):
        world.step(1.0, 0.0)
        if world.truth["collision"]:
            touching += 1
            assert world.truth["threat_index"] == 0, world.frame_index
            assert world.truth["threat_distance"] < 0.03  # the chassis's: a wheel may touch first
    assert touching > 10
    world.close()


def test_obstacles_stay_inside_the_walls_with_room_to_pass():
    world = world_for(arena=(8.0, 8.0), arena_walls=True, n_obstacles=8,
                      obstacle_kinds=("box", "cylinder", "wall", "balloon"),
                      obstacle_field=(-6.0, 12.0, 9.0))  # far beyond the walls
    x0, x1, y0, y1 = world.params.arena_bounds
    for seed in range(25):
        world.reset(seed=seed)
        for _body, _kind, geoms in world.scene.obstacles:
            xy = solid_extent(world, geoms)
            assert xy[:, 0].min() >= x0 + WALL_GAP - 1e-9, seed
            assert xy[:, 0].max() <= x1 - WALL_GAP + 1e-9, seed
            assert xy[:, 1].min() >= y0 + WALL_GAP - 1e-9, seed
            assert xy[:, 1].max() <= y1 - WALL_GAP + 1e-9, seed
        assert not world.truth["collision"]
    world.close()


# -- obstacle_lane and wall_yaw --------------------------------------------------------------


def test_obstacle_lane_keeps_every_footprint_beside_the_path():
    lane = 0.4
    world = world_for(carrier="robot", jitter=0.0, n_obstacles=6, obstacle_lane=lane,
                      obstacle_kinds=("box", "cylinder", "wall", "balloon"),
                      obstacle_field=(1.0, 8.0, 2.0), wall_yaw=(1.0, 1.4))
    sides = set()
    for seed in range(30):
        world.reset(seed=seed)
        for _body, _kind, geoms in world.scene.obstacles:
            y = solid_extent(world, geoms)[:, 1]
            assert y.min() >= lane - 1e-9 or y.max() <= -lane + 1e-9, seed
            sides.add(bool(y.min() > 0))
    assert sides == {True, False}  # both sides of the lane are used
    # driving straight from the start, the robot meets none of them
    for _ in range(270):
        world.step(1.0, 0.0)
    assert world.first_collision_frame == -1 and world.truth["carrier_pos"][0] > 7.5
    world.close()


def test_zero_lane_and_default_wall_yaw_leave_worlds_as_they_were():
    kinds = ("box", "cylinder", "wall")
    base = dict(n_obstacles=6, obstacle_kinds=kinds, obstacle_field=(1.5, 7.0, 2.5))
    # obstacle (x, y, yaw) of seed 5, from the placement before obstacle_lane and wall_yaw
    before = [(3.529772585947237, 0.9055586854470352, 2.020544110227924),
              (5.896285895197011, -0.3027678138038663, 1.322006558090771),
              (6.473228738687284, 2.02260887724261, 0.12378179000591061),
              (5.068653286056314, -1.9065102308303827, -1.350558428711411),
              (3.656292901426112, -1.260795624115996, 1.4612240788492181),
              (2.067457802326842, -2.448830999795714, -0.45837954648751245)]
    for changes in ({}, {"obstacle_lane": 0.0, "wall_yaw": None}, {"wall_yaw": (-0.6, 0.6)}):
        world = world_for(**base, **changes)
        world.reset(seed=5)
        got = [(*world.model.body_pos[b, :2], yaw_of(world, b))
               for b, _k, _g in world.scene.obstacles]
        world.close()
        for (x, y, yaw), (bx, by, byaw) in zip(got, before, strict=True):
            assert (x, y) == (bx, by), changes
            assert math.remainder(yaw - byaw, 2 * math.pi) == pytest.approx(0, abs=1e-12)


@pytest.mark.parametrize("wall_yaw, lo, hi", [(None, -0.6, 0.6), ((1.0, 1.4), 1.0, 1.4),
                                               ((-1.6, -1.5), -1.6, -1.5)])
def test_wall_yaw_sets_the_range_of_wall_obstacles_yaw(wall_yaw, lo, hi):
    world = world_for(n_obstacles=4, obstacle_kinds=("wall", "box"), wall_yaw=wall_yaw,
                      obstacle_field=(1.0, 9.0, 3.0))
    walls, boxes = [], []
    for seed in range(15):
        world.reset(seed=seed)
        for body, kind, _g in world.scene.obstacles:
            (walls if kind == "wall" else boxes).append(yaw_of(world, body))
    world.close()
    assert lo - 1e-9 <= min(walls) and max(walls) <= hi + 1e-9
    assert max(walls) - min(walls) > 0.5 * (hi - lo)  # spread over the range
    assert max(boxes) - min(boxes) > 3.0  # boxes keep turning every way


@pytest.mark.parametrize("changes, match", [
    (dict(wall_yaw=(1.4, 1.0)), "wall_yaw"),
    (dict(wall_yaw=(0.0, 4.0)), "wall_yaw"),
    (dict(wall_yaw=(0.5,)), "wall_yaw"),
    (dict(obstacle_lane=-0.1), "obstacle_lane"),
    (dict(obstacle_lane=2.5, obstacle_field=(1.0, 8.0, 2.5)), "obstacle_lane"),
    (dict(obstacle_lane=0.5, obstacle_ahead=3.0), "obstacle_lane"),
    (dict(arena_walls="yes"), "arena_walls"),
    (dict(arena_walls=True, arena=(1.5, 4.0)), "arena_walls"),
    (dict(arena_walls=True, arena=(8.0, 8.0), jitter=0.0, obstacle_field=(7.0, 9.0, 1.0)),
     "obstacle_field"),
    (dict(arena_walls=True, arena=(8.0, 8.0), jitter=0.0, obstacle_ahead=5.8),
     "obstacle_ahead"),
])
def test_invalid_arena_parameters_raise_one_line_naming_them(changes, match):
    with pytest.raises(ValueError, match=match) as info:
        SceneParams(**changes)
    assert "\n" not in str(info.value)


def test_a_field_with_no_room_beside_the_lane_fails_in_one_line():
    world = world_for(n_obstacles=1, obstacle_kinds=("wall",), wall_yaw=(0.0, 0.0),
                      obstacle_lane=1.9, obstacle_field=(2.0, 4.0, 2.0))
    with pytest.raises(ValueError, match=r"obstacle 0 .*obstacle_lane") as info:
        world.reset(seed=0)  # a wall across the way cannot keep 1.9 m off the path
    assert "\n" not in str(info.value)
    world.close()


# -- the ArenaRoam scenario ----------------------------------------------------------------


def test_arena_roam_is_a_walled_arena_without_goal_that_goes_on_after_collisions():
    p = params_for("ArenaRoam", {})
    assert p.arena_walls and p.carrier == "robot" and p.jitter == 1.0
    assert p.goal_distance == 0 and not p.terminate_on_collision and p.time_limit == 30.0
    assert p.arena_bounds == pytest.approx((-2.0, 6.0, -4.0, 4.0))
    assert p.n_obstacles == 6 and set(p.obstacle_kinds) == {"box", "cylinder", "wall"}
    env = gym.make("lgmd_sim/ArenaRoam-v0", resolution=TINY, scenery=0)
    obs, info = env.reset(seed=3)
    assert "goal" not in obs and "goal_bearing" not in info
    assert env.unwrapped.world.scene.n_threats == 6 + len(WALLS)
    env.close()
