"""What the carrier's camera sees of the threats (`lgmd_sim.world.truth`) at a frame.

A threat owner (a static obstacle, an arena wall, the mover) is *seen* when some line of
sight from the camera, inside the frame, meets one of its geoms before anything else:

- *in view*: the line of sight leaves the camera in front of its near clip plane and
  within its field of view (``fovy`` up and down, as wide as the frame's aspect ratio
  makes it: the frustum the frame is rendered through);
- *not hidden*: MuJoCo's ray along it (`mujoco.mj_ray`) first meets a geom of that owner,
  not another obstacle, the terrain, the scenery or the goal flag. The carrier's body is
  left out of the rays (the camera sits inside its housing; the robot's wheels stand
  behind the lens), and so are the drawn terrain's tiles: the physics heightfield under
  them stands in for them. A ray then crosses one heightfield, not two for each tile
  (which costs about as much again as the rest of the rays), and what is seen does not
  depend on the tiles' geom groups, which the renderer switches as it picks their level
  of detail: nor, then, on whether frames are rendered.

The lines of sight tried are of two kinds, because neither alone is sound:

- towards each owner's sample points that fall inside the frustum: the centres of its
  solid geoms, and the point of it nearest the carrier as `mujoco.mj_geomDistance` gives
  it (the point whose distance and time to collision the threat carries). They catch a
  small or far obstacle wherever it is, which a grid of rays could pass between; a
  centre lies inside its geom, so an unobstructed ray to it meets the geom.
- through a coarse grid over the frame (`RAY_GRID`): they catch a large surface whose
  sample points are all out of view, e.g. an arena wall or a 'wall' obstacle seen along
  its length, or approached at an angle wider than half the field of view.

An owner is missed only where every part of it that is seen lies between the grid's rays
and none of its sample points is seen: part of a small obstacle peeking out from behind
another, or at the edge of the frame.

`CameraView.threat` is the most threatening of the owners seen, ranked as the ground
truth's threat is (`lgmd_sim.world.truth.Threats.threat`), under the keys of `VIEW_KEYS`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.pieces import HIDDEN
from lgmd_sim.world.truth import FAR, Threats

if TYPE_CHECKING:
    from lgmd_sim.world.core import JitterWorld

__all__ = ["RAY_GRID", "VIEW_KEYS", "CameraView"]

#: Rows and columns of the grid of rays through the frame, one through the centre of each
#: cell: about 9 degrees apart at the default field of view (55 degrees, a 4:3 frame), so
#: that an arena wall or a 'wall' obstacle (0.5 m high and more) within a few metres
#: spans a row.
RAY_GRID = (6, 8)
#: What each key of `CameraView.threat` holds: the ground truth's threat keys
#: (`lgmd_sim.world.core.TRUTH_KEYS`) for the threats the camera sees only.
VIEW_KEYS: dict[str, str] = {
    "view_threat_index": "the most threatening of the threats the camera sees (one touched "
                         "in the frame first, else the soonest to collide, else the nearest), "
                         "numbered as threat_index; -1: none seen",
    "view_threat_distance": "its surface distance from the carrier (m; inf: none seen)",
    "view_threat_bearing": "its bearing from the camera's heading, positive to the left (rad)",
    "view_threat_closing_speed": "its closing speed, positive when approaching (m/s)",
    "view_threat_ttc": "its time to collision, distance / closing speed (s; inf when not "
                       "closing or none seen)",
}
#: Geom groups a line of sight meets: 0 (everything drawn) and `HIDDEN` (the physics
#: terrain); not 3, the carriers' undrawn housings.
_SIGHT_GROUPS = np.array([group in (0, HIDDEN) for group in range(6)], np.uint8)
#: The group the drawn terrain tiles are set aside in while the rays are cast: one that
#: `_SIGHT_GROUPS` leaves out.
_ASIDE = 5


class CameraView:
    """Which threat owners the camera of `world` sees in the world's current state.

    Owners are numbered as `lgmd_sim.world.truth.Threats` numbers them (the
    ``threat_index`` of the ground truth).
    """

    def __init__(self, world: JitterWorld) -> None:
        m, sc = world.model, world.scene
        self.model, self.data, self.scene = m, world.data, sc
        tan_y = math.tan(math.radians(float(m.cam_fovy[sc.camera])) / 2)
        tan_x = tan_y * world.width / world.height
        self._tan = np.array([tan_x, tan_y])
        self._near = float(m.vis.map.znear * m.stat.extent)  # as MuJoCo's renderer clips
        rows, cols = RAY_GRID
        x = ((2 * np.arange(cols) + 1) / cols - 1) * tan_x
        y = (1 - (2 * np.arange(rows) + 1) / rows) * tan_y
        # directions in the camera's frame: x right, y up, looking along -z
        self._grid = np.stack([*np.meshgrid(x, y), -np.ones((rows, cols))], -1).reshape(-1, 3)
        self._grid_hit = np.empty(rows * cols, np.int32)
        self._grid_dist = np.empty(rows * cols)
        self._hit = np.empty(1, np.int32)
        self._fromto = np.empty(6)
        self._owner_of = self._owners()
        self._solid = [sc.threat_geoms[sc.threat_owner == i] for i in range(sc.n_threats)]
        self._threats = Threats(m, world.data, sc, world.params)

    def new_episode(self) -> None:
        """Take the sizes of this episode's obstacles: call after each reset."""
        self._threats.new_episode()

    def threat(self, truth: Mapping[str, Any]) -> dict[str, Any]:
        """The most threatening of the threats the camera sees now (`seen`), ranked as the
        ground truth's threat is, from the world's `truth` of this frame (its ``info``:
        the camera's position and velocity; in a frame with a collision, its threat is
        the one touched): the keys of `VIEW_KEYS`."""
        axes = self.data.cam_xmat[self.scene.camera].reshape(3, 3)
        touched = frozenset({truth["threat_index"]}) if truth["collision"] else frozenset()
        # as the world's ground truth: the camera looks along its -z, its -x is to the left
        threat = self._threats.threat(np.asarray(truth["camera_pos"]),
                                      axes @ truth["camera_linvel"], -axes[:, 2],
                                      -axes[:, 0], touched, among=self.seen())
        return {f"view_{key}": value for key, value in threat.items()}

    def seen(self) -> frozenset[int]:
        """The owners the camera sees now (in view and not hidden: see the module)."""
        m, d, sc = self.model, self.data, self.scene
        origin = d.cam_xpos[sc.camera]
        axes = d.cam_xmat[sc.camera].reshape(3, 3)  # columns: the camera's axes
        tile_groups = m.geom_group[sc.tile_geoms]
        m.geom_group[sc.tile_geoms] = _ASIDE
        try:
            seen = self._seen_by_grid(origin, axes)
            unseen = [i for i in range(sc.n_threats) if i not in seen]
            points, owners = self._samples(unseen)
            local = (points - origin) @ axes
            depth = -local[:, 2]
            inside = (depth > self._near) & (
                np.abs(local[:, :2]) <= self._tan * depth[:, None]).all(axis=1)
            for point, owner in zip(points[inside], owners[inside], strict=True):
                if owner not in seen and self._first_owner(origin, point - origin) == owner:
                    seen.add(int(owner))
        finally:
            m.geom_group[sc.tile_geoms] = tile_groups
        return frozenset(seen)

    def _seen_by_grid(self, origin: np.ndarray, axes: np.ndarray) -> set[int]:
        rays = self._grid @ axes.T
        mujoco.mj_multiRay(self.model, self.data, origin, rays.ravel(), _SIGHT_GROUPS, 1,
                           self.scene.carrier_body, self._grid_hit, self._grid_dist, None,
                           len(rays), FAR)
        owners = self._owner_of[self._grid_hit]
        return {int(i) for i in owners[owners >= 0]}

    def _samples(self, owners: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """The sample points of `owners` and the owner of each: their solid geoms' centres,
        then the point of each nearest the carrier."""
        m, d, sc = self.model, self.data, self.scene
        wanted = np.zeros(sc.n_threats, bool)
        wanted[owners] = True
        mine = wanted[sc.threat_owner]
        nearest = np.empty((len(owners), 3))
        for k, i in enumerate(owners):
            gap = math.inf
            for g in self._solid[i]:
                dist = mujoco.mj_geomDistance(m, d, sc.carrier_main_geom, int(g), FAR,
                                              self._fromto)
                if dist < gap:
                    gap, nearest[k] = dist, self._fromto[3:]
        return (np.concatenate([d.geom_xpos[sc.threat_geoms[mine]], nearest]),
                np.concatenate([sc.threat_owner[mine], owners]).astype(int))

    def _first_owner(self, origin: np.ndarray, direction: np.ndarray) -> int:
        """The owner of the first geom the ray from `origin` along `direction` meets (-1:
        none, or a geom no threat owns)."""
        mujoco.mj_ray(self.model, self.data, origin, direction, _SIGHT_GROUPS, 1,
                      self.scene.carrier_body, self._hit)
        return int(self._owner_of[self._hit[0]])

    def _owners(self) -> np.ndarray:
        """The threat owner of each geom a line of sight may meet (-1: none), with one more
        entry, -1, where a ray that meets nothing (geom -1) looks it up."""
        m, sc = self.model, self.scene
        owner_of = np.full(m.ngeom + 1, -1)
        # every geom of an obstacle's body (a balloon's string, too) shows the obstacle
        for i, (_body, _kind, geoms) in enumerate(sc.obstacles):
            owner_of[geoms] = i
        owner_of[sc.threat_geoms] = sc.threat_owner
        if sc.mover_body >= 0:
            owner_of[sc.mover_geoms] = sc.n_threats - 1
        # Each arena wall is drawn as a checkered plane just in front of its box's inner
        # face (`lgmd_sim.world.pieces`): a ray meets that plane first.
        faces = [g for g in np.flatnonzero((m.geom_bodyid == 0)
                                           & (m.geom_type == mujoco.mjtGeom.mjGEOM_PLANE))
                 if g != sc.ground_geom]
        if sc.wall_geoms:
            walls = np.array(sc.wall_geoms)
            for face in faces:
                apart = np.linalg.norm(m.geom_pos[walls] - m.geom_pos[face], axis=1)
                owner_of[face] = owner_of[walls[apart.argmin()]]
        return owner_of
