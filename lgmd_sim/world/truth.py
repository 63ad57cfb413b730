"""The jitter world's ground truth of what the carrier may hit: which threats a contact joins
to it now (`Threats.touching`), whether one may before the next frame (`Threats.may_touch`,
so that the contacts are read only then), and the most threatening obstacle, arena wall or
mover with its distance, bearing, closing speed and time to collision (`Threats.threat`).

A threat is an owner of geoms: the static obstacles 0..n-1, then the arena walls (front,
back, left, right), then the mover. `lgmd_sim.world.core.JitterWorld` asks each frame,
and puts the answers in its ``truth`` (`lgmd_sim.world.core.TRUTH_KEYS`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import SceneParams
from lgmd_sim.world.scene import Scene

__all__ = ["CLOSING_SPEED_MARGIN", "FAR", "Threats", "bearing"]

#: A distance query returns this when nothing is nearer (m).
FAR = 1000.0
#: Above any closing speed of a carrier's geom and a threat's (m/s), beside twice the
#: carrier's top speed and the mover's: the reach within which `Threats.may_touch` looks.
CLOSING_SPEED_MARGIN = 10.0


class Threats:
    """What the carrier of one world may hit, read from the world's MuJoCo state.

    Args:
        model, data: the world's MuJoCo model and data.
        scene: the world's compiled scene (its carrier's and threats' geoms).
        params: the world's parameters (speeds and physics steps of a frame).
    """

    def __init__(self, model: Any, data: Any, scene: Scene, params: SceneParams) -> None:
        self.model, self.data, self.scene = model, data, scene
        self._hit = self._collision_table()
        self._owner_of = np.full(self.model.ngeom, -1)  # threat owner of each geom
        self._owner_of[self.scene.threat_geoms] = self.scene.threat_owner
        self._fromto = np.zeros(6)
        self._vel = np.zeros(6)
        # threat_geoms are grouped by owner: where each owner's run starts.
        self._owner_start = np.flatnonzero(np.diff(self.scene.threat_owner, prepend=-1))
        self._owner_geoms = [[int(g) for g in self.scene.threat_geoms[self.scene.threat_owner == i]]
                             for i in range(self.scene.n_threats)]
        self._threat_rbound = np.zeros(len(self.scene.threat_geoms))  # per episode
        # Bounding spheres plus contact margins (per episode, as the obstacles' sizes), for
        # `may_touch`; a plane's rbound is 0 (unbounded): it may always touch.
        self._carrier_reach = np.zeros(len(self.scene.carrier_geoms))
        self._threat_reach = np.zeros(len(self.scene.threat_geoms))
        self._frame_reach = (CLOSING_SPEED_MARGIN + 2 * (params.max_speed + params.mover_speed)
                             ) * params.substeps * self.model.opt.timestep
        self._has_mover = params.mover != "none"  # then the last threat owner
        # Arena walls: their bounding spheres (half a wall long) rank nothing, so the exact
        # distance of every wall is computed each frame.
        self._walls = tuple(range(params.n_obstacles,
                                  params.n_obstacles + len(self.scene.wall_geoms)))

    def new_episode(self) -> None:
        """Take the sizes of this episode's obstacles (once they are placed)."""
        m, sc = self.model, self.scene
        self._threat_rbound = m.geom_rbound[sc.threat_geoms]
        self._carrier_reach = self._reach(sc.carrier_geoms)
        self._threat_reach = self._reach(sc.threat_geoms)

    def threat(self, cam_pos: np.ndarray, cam_vel: np.ndarray, forward: np.ndarray,
               left: np.ndarray, touched: frozenset[int],
               among: frozenset[int] | None = None) -> dict[str, Any]:
        """The most threatening obstacle or arena wall: one touched in this frame (in
        `touched`), else the soonest to collide, else the nearest. With `among`, the most
        threatening of those threats only (`lgmd_sim.world.view`: those the camera sees),
        ranked the same way; none where it holds none.

        Bounding spheres rank the obstacles and the mover cheaply; the exact surface
        distance (MuJoCo's geom distance from the carrier's main geom) is computed for the
        candidates, the soonest and the nearest of them, every arena wall and those
        touched, and decides between them.
        """
        m, d, sc = self.model, self.data, self.scene
        n = sc.n_threats
        if n == 0 or (among is not None and not among):
            return {"threat_index": -1, "threat_distance": math.inf, "threat_bearing": 0.0,
                    "threat_closing_speed": 0.0, "threat_ttc": math.inf}
        mover_vel = None
        if self._has_mover:
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, sc.mover_body, self._vel, 0)
            mover_vel = self._vel[3:].copy()
        candidates = {0, *self._walls, *touched}
        if n > 1:
            rel_vel = np.empty((n, 3))
            rel_vel[:] = -cam_vel
            if mover_vel is not None:
                rel_vel[-1] += mover_vel
            towards = d.geom_xpos[sc.threat_geoms] - cam_pos
            centre_dist = np.sqrt(np.einsum("ij,ij->i", towards, towards))
            rough = np.minimum.reduceat(centre_dist - self._threat_rbound, self._owner_start)
            rough[list(self._walls)] = np.inf
            if among is not None:  # the others are no candidates
                rough[[i for i in range(n) if i not in among]] = np.inf
            first = self._owner_start
            closing = -np.einsum("ij,ij->i", rel_vel, towards[first]) / centre_dist[first]
            ttc = np.maximum(rough, 0.0) / np.where(closing > 1e-6, closing, 1e-300)
            candidates = {int(ttc.argmin()), int(rough.argmin()), *self._walls, *touched}
        if among is not None:
            candidates &= among
        best: tuple[tuple[bool, float, float], int, np.ndarray, float] | None = None
        for i in candidates:
            dist = math.inf
            for geom in self._owner_geoms[i]:
                gap = mujoco.mj_geomDistance(m, d, sc.carrier_main_geom, geom, FAR,
                                             self._fromto)
                if gap < dist:
                    dist, point = gap, self._fromto[3:] - cam_pos
            unit = point / max(math.sqrt(point @ point), 1e-9)
            rel = -cam_vel if (mover_vel is None or i < n - 1) else mover_vel - cam_vel
            speed = -float(rel @ unit)
            ttc = max(dist, 0.0) / speed if speed > 1e-6 else math.inf
            # One touched comes first: pressed against it at an angle, the carrier may
            # close on it no more (its nearest point beside the camera) while it still
            # closes on something far, an arena wall always.
            key = (i not in touched, ttc, dist)
            if best is None or key < best[0]:
                best = (key, i, unit, speed)
        (_apart, ttc_i, dist_i), i, unit, speed = best
        return {"threat_index": i, "threat_distance": float(dist_i),
                "threat_bearing": bearing(unit, forward, left),
                "threat_closing_speed": speed, "threat_ttc": float(ttc_i)}

    def may_touch(self) -> bool:
        """Whether a contact may join the carrier to a threat before the next frame: some
        carrier geom's reach and some threat geom's are nearer to each other than the two
        can close in a frame at `CLOSING_SPEED_MARGIN` above the carrier's and the mover's
        top speeds. Where none are, no contact can be between them (`touching` finds
        none), and reading the contacts at each physics step is skipped."""
        pos = self.data.geom_xpos
        apart = pos[self.scene.carrier_geoms][:, None] - pos[self.scene.threat_geoms][None]
        gap = (np.sqrt(np.einsum("ijk,ijk->ij", apart, apart))
               - self._carrier_reach[:, None] - self._threat_reach[None])
        return bool((gap < self._frame_reach).any())

    def touching(self) -> frozenset[int]:
        """The threats (owner indices) that a contact joins to the carrier now."""
        g = self.data.contact.geom
        hit = self._hit[g[:, 0], g[:, 1]]
        if not hit.any():
            return frozenset()
        # of each pair, the carrier's geom owns nothing (-1)
        return frozenset(self._owner_of[g[hit]].max(axis=1).tolist())

    def _collision_table(self) -> np.ndarray:
        n = self.model.ngeom
        table = np.zeros((n, n), bool)
        for c in self.scene.carrier_geoms:
            table[c, self.scene.threat_geoms] = True
            table[self.scene.threat_geoms, c] = True
        return table

    def _reach(self, geoms: np.ndarray) -> np.ndarray:
        """How far from their centres `geoms` may make a contact: bounding sphere and
        contact margin (infinite for a plane, whose rbound is 0)."""
        m = self.model
        reach = m.geom_rbound[geoms] + m.geom_margin[geoms]
        return np.where(m.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_PLANE, np.inf, reach)


def bearing(v: np.ndarray, forward: np.ndarray, left: np.ndarray) -> float:
    """Angle (rad) of direction v from the camera's forward axis, positive to the left."""
    return math.atan2(float(v @ left), float(v @ forward))
