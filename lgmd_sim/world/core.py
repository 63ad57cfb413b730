"""The jitter world: physics, camera frames and exact ground truth, one frame at a time.

>>> from lgmd_sim.world import JitterWorld, SceneParams
>>> world = JitterWorld(SceneParams(carrier="robot", jitter=1.0, resolution="paper"))
>>> world.reset(seed=0)
>>> world.step(v=0.8, omega=0.0)          # one camera frame: 1/fps seconds of physics
>>> world.rgb, world.grey                 # the frame (new arrays every frame)
>>> world.truth                            # ground truth of that frame (a dict)
>>> world.render_camera()                  # a bare render of the current state
>>> world.close()

``JitterWorld(params, ssim=True)`` adds ``truth["ssim"]``, each frame's SSIM with the
previous one (NaN on frame 0): a streaming SSIM costs about a twentieth of a frame's
render, so only a consumer that reads it asks (datasets, the demo).

A frameless world (``frame="none"``) renders nothing on reset and step: ``rgb`` and
``grey`` stay black, ``truth["ssim"]`` (where asked for) is NaN, and no GL context is
opened until
`render_camera` or `render_chase` asks for a view. Rendering draws no random numbers and
touches nothing the physics reads, so physics and every other truth key are the same bit
for bit as with frames.

Each episode is seeded: terrain, obstacles, the mover, scenery, light and shake all come
from ``reset(seed)``; the same seed on the same machine gives bit-identical frames and
ground truth. The model is compiled once per world (`lgmd_sim.world.scene`); episodes
rewrite it in place (`lgmd_sim.world.randomise`). The truth of what the carrier may hit
(contacts, the threat) is `lgmd_sim.world.truth`'s.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np

from lgmd_sim.world import randomise, terrain
from lgmd_sim.world import scene as scene_mod
from lgmd_sim.world.carriers import HeldPath, wheel_speeds
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import SceneParams
from lgmd_sim.world.pieces import HIDDEN
from lgmd_sim.world.render import OffscreenRenderer, SSIMStream
from lgmd_sim.world.truth import Threats, bearing

#: Physics time to let the robot settle on the terrain before the first frame (s).
SETTLE_TIME = 0.5
#: Terrain tiles are drawn coarse where a fine cell would span fewer pixels than this.
LOD_PIXELS = 3.0
#: IMU saturation, as a typical MEMS IMU: +-2000 deg/s, +-16 g.
GYRO_RANGE = math.radians(2000.0)
ACCEL_RANGE = 16 * 9.81
#: Wheel speed bound (rad/s) of the proprioception: beyond any the servos reach.
WHEEL_RANGE = 100.0
#: Bound of each component of a frame-to-frame rotation vector (rad).
ROTATION_RANGE = math.pi
#: Bounds of the proprioception vector (wheels, gyro, accelerometer, IMU rotation).
PROPRIO_RANGE = np.array([WHEEL_RANGE] * 2 + [GYRO_RANGE] * 3 + [ACCEL_RANGE] * 3
                         + [ROTATION_RANGE] * 3)
#: What each key of ``truth`` holds, as the environments' ``info`` passes it on (the
#: scenario reference, docs/reference/scenarios.md, is made from it).
TRUTH_KEYS: dict[str, str] = {
    "time": "simulated time of the frame (s)",
    "frame_index": "the frame within the episode, 0 on reset",
    "carrier_pos": "carrier position, world frame (m)",
    "carrier_quat": "carrier orientation, quaternion (w, x, y, z)",
    "camera_pos": "camera position, world frame (m)",
    "camera_quat": "camera orientation, quaternion (w, x, y, z)",
    "camera_angvel": "camera angular velocity, camera frame: x right, y up, z backwards "
                     "(rad/s)",
    "camera_linvel": "camera linear velocity, camera frame (m/s)",
    "pose_rotation": "the camera's rotation since the previous frame from its poses, a "
                     "rotation vector in the previous camera frame (rad; 0 on reset)",
    "imu_rotation": "the same rotation from the IMU: the camera's angular velocity "
                    "integrated over the frame's physics steps, with gyro_noise and "
                    "gyro_bias (rad; 0 on reset)",
    "collision": "the carrier touches an obstacle, an arena wall or the mover in this frame",
    "first_collision_frame": "the episode's first collision frame so far (-1: none yet)",
    "threat_index": "the most threatening object (one touched in the frame first, else the "
                    "soonest to collide, else the nearest): static obstacles 0..n-1, then "
                    "the arena walls (front, back, left, right), then the mover; -1: none",
    "threat_distance": "its surface distance from the carrier (m; inf: none)",
    "threat_bearing": "its bearing from the camera's heading, positive to the left (rad)",
    "threat_closing_speed": "its closing speed, positive when approaching (m/s)",
    "threat_ttc": "its time to collision, distance / closing speed (s; inf when not closing)",
    "goal_distance": "distance from the camera to the goal, on the ground plane (m; only "
                     "with a goal)",
    "goal_bearing": "bearing of the goal from the camera's heading, positive to the left "
                    "(rad; only with a goal)",
    "ssim": "SSIM of the frame with the previous one (NaN on reset and without frames; "
            "only with ssim=True)",
}


class JitterWorld:
    """A MuJoCo world with a camera carrier, obstacles and a moving object.

    Args:
        params: what the world contains and how it is seen (see `SceneParams`).
        ssim: add ``truth["ssim"]``, the SSIM of each frame with the previous one.
    """

    def __init__(self, params: SceneParams, *, ssim: bool = False) -> None:
        self.params = params
        self.scene = scene_mod.build(params)
        self.model = self.scene.model
        self.data = mujoco.MjData(self.model)
        self.height, self.width = params.size
        self.rgb = np.zeros((self.height, self.width, 3), np.uint8)
        self.grey = np.zeros((self.height, self.width), np.uint8)
        self.truth: dict[str, Any] = {}
        self._renderer: OffscreenRenderer | None = None  # made on first use: GL per process
        self._ssim = SSIMStream(self.height, self.width) if ssim else None
        self._threats = Threats(self.model, self.data, self.scene, params)
        self._vel = np.zeros(6)
        self._heights: np.ndarray | None = None
        self._held: HeldPath | None = None
        self._sun_diffuse = self.model.light_diffuse[self.scene.sun].copy()
        self._head = (self.model.vis.headlight.ambient.copy(),
                      self.model.vis.headlight.diffuse.copy())
        self._light_events: randomise.LightEvents = (0.0, 1.0, 1.0, 0.0)
        # Terrain level of detail: the horizontal half field of view (plus a margin for
        # roll) and the distance beyond which a fine cell would span < LOD_PIXELS pixels.
        fovy = math.radians(params.fovy)
        self._half_fov = math.atan(math.tan(fovy / 2) * self.width / self.height) + 0.15
        focal = self.height / (2 * math.tan(fovy / 2))
        self._lod_distance = params.terrain_cell * focal / LOD_PIXELS
        self._tile_radius = terrain.TILE_CELLS * params.terrain_cell / math.sqrt(2)
        # The IMU: the camera's rotation over the last frame interval, from the poses and
        # integrated from the gyro (with its noise and bias, from their own generator).
        self._camera_quat = np.array([1.0, 0.0, 0.0, 0.0])
        self._imu_quat = np.empty(4)
        self._pose_rotation = np.zeros(3)
        self._imu_rotation = np.zeros(3)
        self._imu_rng = np.random.default_rng(0)
        self._gyro_bias = np.zeros(3)
        self.frame_index = 0
        self.first_collision_frame = -1
        self._closed = False

    # -- episode -------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        """Start an episode: seed the world, settle it, render frame 0."""
        rng = np.random.default_rng(seed)
        m, d, sc, p = self.model, self.data, self.scene, self.params
        mujoco.mj_resetData(m, d)
        # The order of these calls is the order of the draws from rng (see randomise).
        self._heights = randomise.seed_terrain(rng, m, sc, p)
        renderer = self._renderer
        if self._heights is not None and renderer is not None and not renderer.closed:
            # a live renderer keeps the last episode's heights; a new one reads the model
            for h in sc.tile_hfields.ravel():
                renderer.upload_hfield(int(h))
        self._light_events = randomise.seed_light(rng, m, sc, p)
        randomise.seed_scenery(rng, m, sc, p)
        randomise.seed_obstacles(rng, m, sc, p, self.ground_height)
        self._held = randomise.place_carrier(rng, m, d, sc, p, self.ground_height)
        self._settle()
        randomise.launch_mover(rng, m, d, sc, p, self._heights)
        self._threats.new_episode()
        d.time = 0.0
        self._apply_light(0.0)
        mujoco.mj_forward(m, d)
        self.frame_index = 0
        self.first_collision_frame = -1
        if self._ssim is not None:
            self._ssim.reset()
        # drawn last, so that the rest of the episode is the same with or without them
        self._imu_rng = np.random.default_rng(rng.integers(2**63))
        self._gyro_bias = self._imu_rng.normal(0.0, math.radians(p.gyro_bias), 3)
        self._pose_rotation[:] = 0.0
        self._imu_rotation[:] = 0.0
        mujoco.mju_mat2Quat(self._camera_quat, d.cam_xmat[sc.camera])
        self._observe(self._threats.touching())

    def _settle(self) -> None:
        """Let the robot come to rest on the ground before the episode's first frame."""
        if not self.scene.wheel_actuators.size:
            return
        m, d = self.model, self.data
        mujoco.mj_step(m, d, nstep=round(SETTLE_TIME / m.opt.timestep))
        d.qvel[:] = 0.0
        d.qacc_warmstart[:] = 0.0
        mujoco.mj_forward(m, d)

    def step(self, v: float, omega: float) -> None:
        """Advance one frame under body velocity command (v m/s, omega rad/s).

        The command is followed as the carrier allows: the robot's wheel servos (torque
        limited), the hand-held rig's path; a tripod ignores it.
        """
        m, d, sc = self.model, self.data, self.scene
        n = self.params.substeps
        poses = None  # per physics step target poses of a moving hand-held / tripod rig
        if sc.wheel_actuators.size:
            d.ctrl[sc.wheel_actuators] = wheel_speeds(v, omega, sc.wheel_radius, sc.wheel_track)
        elif self._held.moving:
            poses = self._held.advance(v, omega, n)
        self._apply_light(d.time + n * m.opt.timestep)
        touched: frozenset[int] = frozenset()
        # mj_step2 then mj_step1 (the split step): after the loop the state, kinematics,
        # contacts and sensors all belong to the same instant, so no extra mj_forward.
        if poses is not None:
            mocap_pos, mocap_quat = d.mocap_pos[sc.mocap], d.mocap_quat[sc.mocap]  # views
        gyro = self._gyro_readings(n)
        imu, vel = self._imu_quat, self._vel
        imu[:] = (1.0, 0.0, 0.0, 0.0)
        # The contacts are read at every physics step, so that a touch in one is never
        # missed, but only in frames where some carrier geom may reach a threat's.
        may_touch = self._may_touch()
        for k in range(n):
            if poses is not None:
                mocap_pos[:] = poses[0][k]
                mocap_quat[:] = poses[1][k]
            mujoco.mj_step2(m, d)
            mujoco.mj_step1(m, d)
            if may_touch and d.ncon and not touched:
                touched = self._threats.touching()
            # The velocity that moved the camera in this physics step (the integrator's
            # new one), in the camera's frame: integrated, it gives the rotation exactly.
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_CAMERA, sc.camera, vel, 1)
            mujoco.mju_quatIntegrate(imu, vel[:3] + gyro[k], m.opt.timestep)
        self.frame_index += 1
        self._observe(touched, turned=True)

    def _gyro_readings(self, n: int) -> np.ndarray:
        """The gyro's error at each of n physics steps: bias plus white noise (rad/s)."""
        if self.params.gyro_noise == 0:
            return np.broadcast_to(self._gyro_bias, (n, 3))
        sigma = math.radians(self.params.gyro_noise) / math.sqrt(self.model.opt.timestep)
        return self._gyro_bias + self._imu_rng.normal(0.0, sigma, (n, 3))

    def _camera_turn(self) -> np.ndarray:
        """The camera's rotation since the last call (rotation vector, rad, in the earlier
        camera frame), from its poses."""
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, self.data.cam_xmat[self.scene.camera])
        inverse, turn, rotation = np.empty(4), np.empty(4), np.empty(3)
        mujoco.mju_negQuat(inverse, self._camera_quat)
        mujoco.mju_mulQuat(turn, inverse, q)
        mujoco.mju_quat2Vel(rotation, turn, 1.0)
        self._camera_quat = q
        return rotation

    def _apply_light(self, t: float) -> None:
        """Dim the sun and the sky for time t (s): the passing shade and the flicker."""
        p = self.params
        if p.shade == 0 and p.flicker == 0:
            return
        phase, period, width, flicker_phase = self._light_events
        u = ((t - phase) % period) / width
        shade = p.shade * 0.5 * (1 - math.cos(2 * math.pi * u)) if u < 1 else 0.0
        flicker = 1 + p.flicker * math.sin(2 * math.pi * p.flicker_hz * t + flicker_phase)
        m = self.model
        m.light_diffuse[self.scene.sun] = self._sun_diffuse * (1 - shade) * flicker
        m.vis.headlight.ambient = self._head[0] * flicker
        m.vis.headlight.diffuse = self._head[1] * flicker

    def render_camera(self, out: np.ndarray | None = None) -> np.ndarray:
        """Render the carrier's camera in the current state (RGB); nothing else.

        The same call a step makes: this, after each step, is the baseline for the
        cost of an environment step.
        """
        return self._render(self.scene.camera, out)

    def render_chase(self) -> np.ndarray:
        """An RGB view from behind and above the carrier."""
        return self._render(self.scene.chase_camera, None)

    def proprio(self) -> np.ndarray:
        """Wheel speeds (rad/s; 0 without wheels), gyro (rad/s), accelerometer (m/s^2),
        and the IMU's rotation of the camera over the last frame interval (``truth
        ["imu_rotation"]``, rad)."""
        d, sc = self.data, self.scene
        raw = np.zeros(11)
        if sc.wheel_dofs.size:
            raw[:2] = d.qvel[sc.wheel_dofs]
        raw[2:8] = d.sensordata[sc.gyro_adr:sc.gyro_adr + 6]  # gyro, then accelerometer
        raw[8:] = self._imu_rotation
        return np.clip(raw, -PROPRIO_RANGE, PROPRIO_RANGE).astype(np.float32)

    def top_view(self) -> dict[str, Any]:
        """A map of this episode seen from above, for figures: the footprints (a polygon
        of (x, y) corners, or a circle: centre and radius) of each static obstacle, then
        of each arena wall (so that ``obstacles[threat_index]`` is the threat's, where it
        is no mover), the goal, and the terrain heights with the extent (x0, x1, y0, y1)
        they cover (m)."""
        m, d = self.model, self.data
        footprints: list[dict[str, Any]] = []
        mains = [geoms[0] for _body, _kind, geoms in self.scene.obstacles]
        for g in mains + self.scene.wall_geoms:
            centre, size = d.geom_xpos[g, :2], m.geom_size[g]
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
                corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * size[:2]
                rot = d.geom_xmat[g].reshape(3, 3)[:2, :2]
                footprints.append({"polygon": (corners @ rot.T + centre).tolist()})
            else:  # cylinders and balloons: a circle
                footprints.append({"circle": [*centre.tolist(), float(size[0])]})
        goal = (d.xpos[self.scene.goal_body, :2].tolist() if self.scene.goal_body >= 0
                else None)
        view: dict[str, Any] = {"obstacles": footprints, "goal": goal}
        if self._heights is not None:
            x0, y0 = self.scene.terrain_origin
            rows, cols = self._heights.shape
            cell = self.params.terrain_cell
            view["terrain"] = self._heights.tolist()
            view["extent"] = [x0, x0 + (cols - 1) * cell, y0, y0 + (rows - 1) * cell]
        return view

    def ground_height(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Terrain height (m) at world points (x, y) in this episode."""
        if self._heights is None:
            return np.zeros(np.broadcast(x, y).shape)
        return terrain.height_at(self._heights, self.params.terrain_cell,
                                 self.scene.terrain_origin, x, y)

    def close(self) -> None:
        """Free the renderer's GL context; safe to call more than once."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self._closed = True

    # -- frames and ground truth ---------------------------------------------------------

    def _render(self, camera: int, out: np.ndarray | None) -> np.ndarray:
        return self._draw(camera).read(out)

    def _draw(self, camera: int) -> OffscreenRenderer:
        """Draw `camera`'s view and start its rasterisation: the renderer's `read` gives
        the frame."""
        if self.scene.tile_geoms.size:
            self._choose_tiles(camera)
        if self._renderer is None or self._renderer.closed:  # first frame, or after a fork
            if self._closed:
                raise RuntimeError("the world is closed")
            self._renderer = OffscreenRenderer(self.model, self.height, self.width,
                                               shadows=self.params.shadows)
        self._renderer.draw(self.data, camera)
        return self._renderer

    def _choose_tiles(self, camera: int) -> None:
        """Level of detail of the drawn terrain: tiles out of the camera's horizontal
        field of view are not drawn, far ones in their coarse version.

        A fine tile switches to coarse where its cells shrink below `LOD_PIXELS` pixels.
        """
        sc, m, d = self.scene, self.model, self.data
        offset = sc.tile_centres - d.cam_xpos[camera, :2]
        dist = np.sqrt(np.einsum("ij,ij->i", offset, offset))
        forward = -d.cam_xmat[camera].reshape(3, 3)[:2, 2]
        norm = math.hypot(forward[0], forward[1])
        if norm < 1e-6:  # looking straight down or up: draw every tile
            visible = np.ones(len(dist), bool)
        else:
            cos_angle = (offset @ forward) / (norm * np.maximum(dist, 1e-9))
            # within the half-FOV plus the angle the tile's bounding circle subtends
            spread = self._half_fov + np.arcsin(np.minimum(self._tile_radius
                                                           / np.maximum(dist, 1e-9), 1.0))
            visible = (dist < self._tile_radius) | (np.arccos(np.clip(cos_angle, -1, 1))
                                                    < spread)
        fine = visible & (dist - self._tile_radius < self._lod_distance)
        groups = m.geom_group
        groups[sc.tile_geoms[:, 0]] = np.where(fine, 0, HIDDEN)
        groups[sc.tile_geoms[:, 1]] = np.where(visible & ~fine, 0, HIDDEN)

    def _observe(self, touched: frozenset[int], *, turned: bool = False) -> None:
        """Render the frame and take its ground truth; with `turned` (after a step), also
        the camera's rotation over the frame interval, from its poses and from its IMU."""
        renderer = self._draw(self.scene.camera) if self.params.frame != "none" else None
        # While the software renderer rasterises the frame in its own threads: the truth
        # reads the state and the model, which the drawing has done with, and writes
        # nothing the frame depends on, so it overlaps the frame instead of following it.
        if turned:
            mujoco.mju_quat2Vel(self._imu_rotation, self._imu_quat, 1.0)
            self._pose_rotation = self._camera_turn()
        if touched and self.first_collision_frame < 0:
            self.first_collision_frame = self.frame_index
        self.truth = self._ground_truth(touched)
        if renderer is not None:
            # Fresh arrays each frame (np.empty is free): callers may keep them as they are.
            self.rgb = renderer.read()
            self.grey = cv2.cvtColor(self.rgb, cv2.COLOR_RGB2GRAY)
        if self._ssim is not None:  # no frames, no similarity between them
            self.truth["ssim"] = self._ssim.push(self.grey) if renderer is not None else math.nan

    def _ground_truth(self, touched: frozenset[int]) -> dict[str, Any]:
        m, d, sc = self.model, self.data, self.scene
        cam = sc.camera
        cam_pos = d.cam_xpos[cam].copy()
        cam_mat = d.cam_xmat[cam].reshape(3, 3)
        cam_quat = np.empty(4)
        mujoco.mju_mat2Quat(cam_quat, d.cam_xmat[cam])
        velocity = np.empty(6)  # angular then linear, in the camera frame
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_CAMERA, cam, velocity, 1)
        forward, left = -cam_mat[:, 2], -cam_mat[:, 0]  # the camera looks along its -z
        truth: dict[str, Any] = {
            "time": float(d.time),
            "frame_index": self.frame_index,
            "carrier_pos": d.xpos[sc.carrier_body].copy(),
            "carrier_quat": d.xquat[sc.carrier_body].copy(),
            "camera_pos": cam_pos,
            "camera_quat": cam_quat,
            "camera_angvel": velocity[:3],
            "camera_linvel": velocity[3:],
            "pose_rotation": self._pose_rotation.copy(),
            "imu_rotation": self._imu_rotation.copy(),
            "collision": bool(touched),
            "first_collision_frame": self.first_collision_frame,
        }
        truth.update(self._threats.threat(cam_pos, cam_mat @ velocity[3:], forward, left,
                                          touched))
        if sc.goal_body >= 0:
            to_goal = d.xpos[sc.goal_body] - cam_pos
            truth["goal_distance"] = math.hypot(to_goal[0], to_goal[1])
            truth["goal_bearing"] = bearing(to_goal, forward, left)
        return truth

    def _may_touch(self) -> bool:
        # the world's own, so that a test can count the frames whose contacts it skips
        return self._threats.may_touch()
