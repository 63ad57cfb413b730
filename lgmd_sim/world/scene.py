"""Build the MuJoCo model of a jitter world from its parameters.

The model's structure (which bodies and geoms exist) depends only on the parameters, so
one compiled model serves every episode of an environment: `lgmd_sim.world.randomise`
seeds each episode by writing positions, sizes, colours, materials, light and terrain
heights into the model in place. The layout: the carrier starts at the origin heading
along +x; the rough terrain patch (a heightfield) spans `arena` from 2 m behind the start
and blends into a flat ground plane; the arena walls (if any) stand around its edges; the
goal (if any) lies straight ahead.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from lgmd_sim.core.resources import assets_dir
from lgmd_sim.world import terrain
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import ARENA_BACK, SceneParams

#: Side of the flat ground plane (m): far beyond anything the camera resolves. It is drawn
#: as 2 x 2 quads (the third plane size is the render grid spacing): a fine grid costs
#: more than the rest of a frame on software GL.
GROUND_SIZE = 200.0
#: Contact bits: ground and obstacles collide with carriers; vehicles only with carriers.
BIT_WORLD, BIT_VEHICLE = 1, 2
#: Ground palettes (RGB 0..255): grass, dry dirt, gravel.
GROUND_PALETTES = (
    ((74, 102, 46), (112, 128, 60), (120, 96, 62)),
    ((140, 110, 78), (168, 140, 100), (104, 82, 60)),
    ((120, 118, 112), (150, 146, 138), (92, 90, 88)),
)
#: Thickness of the heightfields below their lowest point (m).
TERRAIN_BASE = 0.05
#: Geom group the renderer does not draw (the physics terrain, tiles not in view).
HIDDEN = 4
#: Texture tile of the ground (m): blotches of about 5 to 50 cm.
GROUND_TILE = 2.0
TEXTURE_SIZE = 256
#: Names of the carrier's elements (robot.xml / camera_rig.xml) in the world model.
PREFIX = "carrier/"
#: Obstacle materials: index -1 (plain colour) and these textures.
OBSTACLE_TEXTURES = ("checker", "stripes", "blotches")
#: The arena walls, in the order of their geoms and threat indices (after the obstacles').
WALLS = ("front", "back", "left", "right")
#: Arena wall height and thickness (m): above the robot's camera (14 cm) by far, and
#: 50 physics steps of travel at full speed thick.
WALL_HEIGHT, WALL_THICKNESS = 0.5, 0.2
#: The arena walls' checker: squares of this side (m), edges across and along to loom at
#: every distance, in two tints (brick red, sand); their tops and backs are plain.
WALL_CHECK = 0.25
WALL_TINTS = ([0.8, 0.42, 0.3], [0.85, 0.75, 0.55])
WALL_EDGE = [0.55, 0.3, 0.22, 1.0]


@dataclass
class Scene:
    """The compiled model and the ids the world needs to drive and observe it."""

    model: mujoco.MjModel
    params: SceneParams
    carrier_body: int
    carrier_geoms: np.ndarray
    carrier_main_geom: int
    camera: int
    chase_camera: int
    gyro_adr: int
    accel_adr: int
    carrier_qpos_adr: int
    carrier_dof_adr: int
    mocap: int = -1  # handheld / tripod target
    wheel_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    wheel_actuators: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    wheel_radius: float = 0.06
    wheel_track: float = 0.25
    terrain_geom: int = -1  # the physics heightfield (not drawn)
    hfield: int = -1
    terrain_shape: tuple[int, int] = (0, 0)
    terrain_origin: tuple[float, float] = (0.0, 0.0)
    # Drawn tiles: geoms and heightfields (n_tiles, 2: fine, coarse), first grid point
    # (row, col) of each tile, and tile centres (n_tiles, 2) in the world.
    tile_geoms: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    tile_hfields: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    tile_origin: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    tile_centres: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    ground_geom: int = -1  # the flat plane around the rough patch
    ground_materials: tuple[int, ...] = ()
    terrain_materials: tuple[int, ...] = ()
    obstacle_materials: tuple[int, ...] = ()
    sun: int = -1
    # Static obstacles: body id, kind, and geom ids in the order documented in _add_obstacle.
    obstacles: list[tuple[int, str, list[int]]] = field(default_factory=list)
    # The arena walls' geoms, in the order of WALLS (empty without arena_walls).
    wall_geoms: list[int] = field(default_factory=list)
    # The moving object: its kind, body, geoms, joint qpos/dof address and a pivot body.
    mover_kind: str = "none"
    mover_body: int = -1
    mover_geoms: list[int] = field(default_factory=list)
    mover_qpos_adr: int = -1
    mover_dof_adr: int = -1
    mover_pivot: int = -1
    scenery: list[tuple[int, list[int]]] = field(default_factory=list)
    goal_body: int = -1
    # Geoms a collision with the carrier counts for (static obstacles, walls, the mover).
    threat_geoms: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    # threat_geoms[i] belongs to threat threat_owner[i]: the static obstacles in order,
    # then the arena walls, then the mover (always the last owner).
    threat_owner: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    n_threats: int = 0


def build(params: SceneParams) -> Scene:
    """Compile the model for `params` (deterministic: no randomness is used here)."""
    spec = mujoco.MjSpec()
    spec.modelname = "lgmd_sim_world"
    _options(spec, params)
    _assets(spec)
    world = spec.worldbody
    world.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE,
                   size=[GROUND_SIZE / 2, GROUND_SIZE / 2, GROUND_SIZE / 4],
                   material="ground_0", contype=BIT_WORLD, conaffinity=BIT_WORLD)
    if params.resolved_roughness > 0:
        _terrain(spec, params)
    # The sun (its direction is seeded per episode); the headlight is the sky.
    world.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                    dir=[0, 0, -1], diffuse=[0.7, 0.7, 0.66], specular=[0.2, 0.2, 0.2],
                    ambient=[0.1, 0.1, 0.12], castshadow=params.shadows)
    _carrier(spec, params)
    for i in range(params.n_obstacles):
        _add_obstacle(spec, f"obstacle_{i}", params.obstacle_kinds[i % len(params.obstacle_kinds)])
    if params.arena_walls:
        _arena_walls(spec, params)
    if params.mover != "none":
        _add_mover(spec, params.mover)
    for i in range(params.scenery):
        _add_scenery(spec, f"scenery_{i}", tree=i % 3 != 2)
    if params.goal_distance > 0:
        goal = world.add_body(name="goal", pos=[params.goal_distance, 0, 0])
        goal.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0.6], pos=[0, 0, 0.6],
                      rgba=[0.9, 0.9, 0.9, 1], contype=0, conaffinity=0)
        goal.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.005, 0.18, 0.12],
                      pos=[0, 0.18, 1.05], rgba=[0.1, 0.8, 0.2, 1], contype=0, conaffinity=0)
    model = spec.compile()
    return _index(model, params)


# --- model pieces -------------------------------------------------------------------------


def _options(spec: mujoco.MjSpec, params: SceneParams) -> None:
    spec.option.timestep = params.timestep
    # implicitfast: stable with stiff wheel servos at 4 ms steps, and cheap.
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    height, width = params.size
    vis = spec.visual
    vis.global_.offwidth = width
    vis.global_.offheight = height
    vis.quality.shadowsize = 4096 if params.shadows else 0
    vis.quality.offsamples = params.multisample
    # Coarser spheres and cylinders than MuJoCo's default (28 x 16): on software GL the
    # vertex work of a few dozen round geoms otherwise doubles the frame time.
    vis.quality.numslices = 16
    vis.quality.numstacks = 10
    # The headlight stands in for skylight: ambient plus a soft diffuse fill.
    vis.headlight.ambient = [0.35, 0.35, 0.38]
    vis.headlight.diffuse = [0.25, 0.25, 0.25]
    vis.headlight.specular = [0.0, 0.0, 0.0]
    # Clip planes are relative to the model's extent, fixed here at 10 m: near 5 mm (an
    # object touching the camera housing still renders), far 600 m (beyond the scenery).
    spec.stat.extent = 10.0
    vis.map.znear = 0.0005
    vis.map.zfar = 60.0
    vis.rgba.haze = [0.78, 0.84, 0.9, 1]


def _terrain(spec: mujoco.MjSpec, params: SceneParams) -> None:
    """The rough patch: one heightfield for the physics (not drawn) and, for drawing, a
    grid of tiles each in a fine and a coarse version (see `lgmd_sim.world.core`'s level
    of detail: the whole patch at full detail costs several times a frame's other work)."""
    tiles_y, tiles_x = terrain.tile_grid(params.arena, params.terrain_cell)
    tile = terrain.TILE_CELLS * params.terrain_cell
    length, width = tiles_x * tile, tiles_y * tile
    # Heights are stored normalised by the elevation range; 10 RMS heights hold the
    # raised noise with room to spare (values above are clipped).
    top = 10 * params.resolved_roughness
    nrow, ncol = tiles_y * terrain.TILE_CELLS + 1, tiles_x * terrain.TILE_CELLS + 1
    hfield = spec.add_hfield(name="terrain", nrow=nrow, ncol=ncol,
                             size=[length / 2, width / 2, top, TERRAIN_BASE])
    hfield.userdata = [0.0] * (nrow * ncol)  # heights are written per episode
    x0, y0 = -ARENA_BACK, -width / 2
    spec.worldbody.add_geom(name="terrain", type=mujoco.mjtGeom.mjGEOM_HFIELD,
                            hfieldname="terrain", pos=[x0 + length / 2, 0, 0],
                            contype=BIT_WORLD, conaffinity=BIT_WORLD, group=HIDDEN)
    for iy in range(tiles_y):
        for ix in range(tiles_x):
            for lod, step in (("fine", 1), ("coarse", terrain.COARSE_STEP)):
                name = f"terrain_{iy}_{ix}_{lod}"
                n = terrain.TILE_CELLS // step + 1
                h = spec.add_hfield(name=name, nrow=n, ncol=n,
                                    size=[tile / 2, tile / 2, top, TERRAIN_BASE])
                h.userdata = [0.0] * (n * n)
                spec.worldbody.add_geom(
                    name=name, type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname=name,
                    pos=[x0 + (ix + 0.5) * tile, y0 + (iy + 0.5) * tile, 0],
                    material="terrain_0", contype=0, conaffinity=0, group=HIDDEN)


@functools.cache
def _texture_images() -> dict[str, np.ndarray]:
    """The procedural textures (fixed seed: part of the model's structure; episodes choose
    among them by index). Cached: generating them costs more than compiling the model."""
    rng = np.random.default_rng(20240521)
    images = {f"ground_{i}": terrain.ground_texture(rng, TEXTURE_SIZE, np.array(palette))
              for i, palette in enumerate(GROUND_PALETTES)}
    stripes = np.where((np.arange(64) // 8) % 2, 255, 110).astype(np.uint8)
    images["stripes"] = np.repeat(np.repeat(stripes[None, :, None], 64, 0), 3, 2)
    grey = np.array([(230, 230, 230), (150, 150, 150), (95, 95, 95)])
    images["blotches"] = terrain.ground_texture(rng, 128, grey)
    return images


def _material(spec: mujoco.MjSpec, name: str, texture: str | None, *, repeat: float = 1.0,
              uniform: bool = False, specular: float = 0.1, shininess: float = 0.1) -> None:
    mat = spec.add_material(name=name, texrepeat=[repeat, repeat], texuniform=uniform,
                            specular=specular, shininess=shininess)
    if texture:
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = texture


def _assets(spec: mujoco.MjSpec) -> None:
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, width=64, height=64,
                     rgb1=[0.45, 0.62, 0.86], rgb2=[0.86, 0.9, 0.95])
    for name, rgb in _texture_images().items():
        h, w, _ = rgb.shape
        tex = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=w,
                               height=h, nchannel=3)
        tex.data = rgb.tobytes()
    for i in range(len(GROUND_PALETTES)):
        # The plane counts repeats per metre (texuniform); the heightfield per whole patch,
        # set in _index once its size is known.
        _material(spec, f"ground_{i}", f"ground_{i}", repeat=1 / GROUND_TILE, uniform=True)
        _material(spec, f"terrain_{i}", f"ground_{i}")
    spec.add_texture(name="checker", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=64, height=64,
                     rgb1=[1, 1, 1], rgb2=[0.35, 0.35, 0.35])
    for name in OBSTACLE_TEXTURES:
        _material(spec, f"obstacle_{name}", name, repeat=2.0)
    _material(spec, "balloon", None, specular=0.6, shininess=0.7)


def _load(name: str) -> mujoco.MjSpec:
    return mujoco.MjSpec.from_file(str(assets_dir() / name))


def _carrier(spec: mujoco.MjSpec, params: SceneParams) -> None:
    frame = spec.worldbody.add_frame()
    if params.carrier == "robot":
        child = _load("robot.xml")
        root = "robot"
    else:
        child = _load("camera_rig.xml")
        root = "rig"
        # The kinematic target the rig is welded to (moved by lgmd_sim.world.carriers).
        spec.worldbody.add_body(name="rig_target", mocap=True,
                                pos=[0, 0, params.camera_height])
    for cam in ("camera", "chase"):
        child.camera(cam).fovy = params.fovy
    for geom in child.body(root).find_all(mujoco.mjtObj.mjOBJ_GEOM):
        if geom.contype or geom.conaffinity:  # drawn-only parts stay out of contacts
            geom.contype = geom.conaffinity = BIT_WORLD | BIT_VEHICLE
    spec.attach(child, frame=frame, prefix=PREFIX)
    if params.carrier != "robot":
        # Weld data: anchor, relative position, relative quaternion (identity: the rig
        # takes the target's pose, not their compile-time offset), torque scale.
        spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, name1="rig_target", name2=PREFIX + "rig",
                          objtype=mujoco.mjtObj.mjOBJ_BODY, solref=[0.01, 1.0],
                          data=[0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0])


def _geom(body: mujoco.MjsBody, name: str, gtype: mujoco.mjtGeom, *, collide: bool = True,
          bits: int = BIT_WORLD, **kw) -> None:
    c = bits if collide else 0
    body.add_geom(name=name, type=gtype, contype=c, conaffinity=c, size=[0.1, 0.1, 0.1], **kw)


def _add_obstacle(spec: mujoco.MjSpec, name: str, kind: str) -> None:
    """A static obstacle; geoms in order: box/cylinder/wall -> [main];
    balloon -> [balloon, pole, arm, string (visual only)]."""
    body = spec.worldbody.add_body(name=name)
    G = mujoco.mjtGeom
    if kind == "box":
        _geom(body, f"{name}/main", G.mjGEOM_BOX)
    elif kind == "cylinder":
        _geom(body, f"{name}/main", G.mjGEOM_CYLINDER)
    elif kind == "wall":
        _geom(body, f"{name}/main", G.mjGEOM_BOX)
    else:  # balloon hanging from a wooden pole (paper Sec. 4.1.2 b)
        _geom(body, f"{name}/balloon", G.mjGEOM_ELLIPSOID, material="balloon")
        _geom(body, f"{name}/pole", G.mjGEOM_CYLINDER, rgba=[0.55, 0.4, 0.25, 1])
        _geom(body, f"{name}/arm", G.mjGEOM_BOX, rgba=[0.55, 0.4, 0.25, 1])
        _geom(body, f"{name}/string", G.mjGEOM_CYLINDER, collide=False,
              rgba=[0.9, 0.9, 0.9, 1])


def _arena_walls(spec: mujoco.MjSpec, params: SceneParams) -> None:
    """Four walls, their inner faces on the arena's edges; the front and back walls span
    the side walls' ends, so that the corners are closed. Sunk as the obstacles are, into
    ground that the terrain's taper has brought down to zero there.

    Each wall is a plain box (the physics, the threat distances) with a checkered plane
    just in front of its inner face: MuJoCo maps 2D textures across planes, not across a
    box's upright faces, and many checkered panels would cost more than the whole frame."""
    x0, x1, y0, y1 = params.arena_bounds
    t, sink = WALL_THICKNESS, 0.03
    half_z = (WALL_HEIGHT + sink) / 2
    spec.add_texture(name="arena_wall", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=64, height=64,
                     rgb1=WALL_TINTS[0], rgb2=WALL_TINTS[1])
    # uniform on a plane: texture tiles (2 x 2 squares) per 2 m (seen in its frames)
    _material(spec, "arena_wall", "arena_wall", repeat=1 / WALL_CHECK, uniform=True)
    # centre, half size along the wall, inward normal of each wall's inner face
    faces = {"front": ((x1, 0.0), (y1 - y0) / 2 + t, (-1.0, 0.0)),
             "back": ((x0, 0.0), (y1 - y0) / 2 + t, (1.0, 0.0)),
             "left": (((x0 + x1) / 2, y1), (x1 - x0) / 2, (0.0, -1.0)),
             "right": (((x0 + x1) / 2, y0), (x1 - x0) / 2, (0.0, 1.0))}
    up = np.array([0.0, 0.0, 1.0])
    for name in WALLS:
        (cx, cy), half, (nx, ny) = faces[name]
        normal = np.array([nx, ny, 0.0])
        along = np.cross(up, normal)
        centre = np.array([cx, cy, half_z - sink])
        size = np.abs(along) * half + np.abs(normal) * t / 2 + up * half_z
        spec.worldbody.add_geom(name=f"arena_wall_{name}", type=mujoco.mjtGeom.mjGEOM_BOX,
                                pos=centre - normal * t / 2, size=size, rgba=WALL_EDGE,
                                contype=BIT_WORLD, conaffinity=BIT_WORLD)
        quat = np.empty(4)  # the plane's x along the wall, y up, z (its front) inwards
        mujoco.mju_mat2Quat(quat, np.column_stack([along, up, normal]).ravel())
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, pos=centre + normal * 0.005,
                                quat=quat, size=[half, half_z, half], material="arena_wall",
                                contype=0, conaffinity=0)


def _add_mover(spec: mujoco.MjSpec, kind: str) -> None:
    """The moving object; geoms in order: balloon/ball/swing -> [sphere, string?];
    vehicle -> [body, cabin, 4 wheels]."""
    G = mujoco.mjtGeom
    world = spec.worldbody
    if kind in ("balloon", "ball"):
        body = world.add_body(name="mover", gravcomp=1.0 if kind == "balloon" else 0.0)
        body.add_freejoint(name="mover")
        _geom(body, "mover/main", G.mjGEOM_SPHERE, mass=0.05 if kind == "balloon" else 0.45,
              material="balloon" if kind == "balloon" else "obstacle_checker")
        if kind == "balloon":
            _geom(body, "mover/string", G.mjGEOM_CYLINDER, collide=False, mass=0.0,
                  rgba=[0.9, 0.9, 0.9, 1])
    elif kind == "swing":
        pivot = world.add_body(name="mover_pivot")
        _geom(pivot, "mover_pivot/pole", G.mjGEOM_CYLINDER, rgba=[0.55, 0.4, 0.25, 1])
        _geom(pivot, "mover_pivot/arm", G.mjGEOM_BOX, rgba=[0.55, 0.4, 0.25, 1])
        body = pivot.add_body(name="mover")
        body.add_joint(name="mover", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                       damping=0.002)
        _geom(body, "mover/main", G.mjGEOM_SPHERE, mass=0.3, material="balloon")
        _geom(body, "mover/string", G.mjGEOM_CYLINDER, collide=False, mass=0.0,
              rgba=[0.9, 0.9, 0.9, 1])
    else:  # vehicle on a straight track: constant speed, no ground contact
        body = world.add_body(name="mover")
        body.add_joint(name="mover", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
        _geom(body, "mover/main", G.mjGEOM_BOX, bits=BIT_VEHICLE, mass=900.0)
        _geom(body, "mover/cabin", G.mjGEOM_BOX, bits=BIT_VEHICLE, mass=100.0,
              rgba=[0.15, 0.2, 0.25, 1])
        for k in range(4):
            _geom(body, f"mover/wheel_{k}", G.mjGEOM_CYLINDER, collide=False, mass=0.0,
                  rgba=[0.08, 0.08, 0.08, 1], euler=[90, 0, 0])


def _add_scenery(spec: mujoco.MjSpec, name: str, *, tree: bool) -> None:
    body = spec.worldbody.add_body(name=name)
    G = mujoco.mjtGeom
    if tree:
        _geom(body, f"{name}/trunk", G.mjGEOM_CYLINDER, collide=False, rgba=[0.4, 0.3, 0.2, 1])
        _geom(body, f"{name}/crown", G.mjGEOM_ELLIPSOID, collide=False,
              material="obstacle_blotches")
    else:
        _geom(body, f"{name}/block", G.mjGEOM_BOX, collide=False, material="obstacle_stripes")
        _geom(body, f"{name}/roof", G.mjGEOM_BOX, collide=False)


# --- ids ----------------------------------------------------------------------------------


def _id(model: mujoco.MjModel, obj: mujoco.mjtObj, name: str) -> int:
    i = mujoco.mj_name2id(model, obj, name)
    if i < 0:
        raise RuntimeError(f"lgmd_sim world model lacks {obj.name} {name!r}")
    return i


def _body_geoms(model: mujoco.MjModel, body: int) -> list[int]:
    return [int(g) for g in np.flatnonzero(model.geom_bodyid == body)]


def _index(model: mujoco.MjModel, params: SceneParams) -> Scene:
    obj = mujoco.mjtObj
    robot = params.carrier == "robot"
    carrier = _id(model, obj.mjOBJ_BODY, PREFIX + ("robot" if robot else "rig"))
    carrier_geoms = [g for g in range(model.ngeom) if model.geom_contype[g]
                     and model.body_rootid[model.geom_bodyid[g]] == carrier]
    joint = _id(model, obj.mjOBJ_JOINT, PREFIX + ("robot" if robot else "rig"))
    scene = Scene(
        model=model,
        params=params,
        carrier_body=carrier,
        carrier_geoms=np.array(carrier_geoms),
        carrier_main_geom=_id(model, obj.mjOBJ_GEOM,
                              PREFIX + ("chassis" if robot else "camera_housing")),
        camera=_id(model, obj.mjOBJ_CAMERA, PREFIX + "camera"),
        chase_camera=_id(model, obj.mjOBJ_CAMERA, PREFIX + "chase"),
        gyro_adr=int(model.sensor_adr[_id(model, obj.mjOBJ_SENSOR, PREFIX + "gyro")]),
        accel_adr=int(model.sensor_adr[_id(model, obj.mjOBJ_SENSOR, PREFIX + "accelerometer")]),
        carrier_qpos_adr=int(model.jnt_qposadr[joint]),
        carrier_dof_adr=int(model.jnt_dofadr[joint]),
        sun=_id(model, obj.mjOBJ_LIGHT, "sun"),
        ground_geom=_id(model, obj.mjOBJ_GEOM, "ground"),
        ground_materials=tuple(_id(model, obj.mjOBJ_MATERIAL, f"ground_{i}")
                               for i in range(len(GROUND_PALETTES))),
        obstacle_materials=tuple(_id(model, obj.mjOBJ_MATERIAL, f"obstacle_{t}")
                                 for t in OBSTACLE_TEXTURES),
    )
    if scene.accel_adr != scene.gyro_adr + 3:
        raise RuntimeError("carrier MJCF: the accelerometer must follow the gyro")
    if robot:
        wheels = (PREFIX + "wheel_left", PREFIX + "wheel_right")
        scene.wheel_dofs = np.array([model.jnt_dofadr[_id(model, obj.mjOBJ_JOINT, w)]
                                     for w in wheels])
        scene.wheel_actuators = np.array([_id(model, obj.mjOBJ_ACTUATOR, w) for w in wheels])
        left = _id(model, obj.mjOBJ_GEOM, wheels[0])
        scene.wheel_radius = float(model.geom_size[left, 0])
        scene.wheel_track = 2 * abs(float(model.body_pos[_id(model, obj.mjOBJ_BODY, wheels[0]), 1]))
    else:
        scene.mocap = int(model.body_mocapid[_id(model, obj.mjOBJ_BODY, "rig_target")])
    if params.resolved_roughness > 0:
        scene.terrain_geom = _id(model, obj.mjOBJ_GEOM, "terrain")
        scene.hfield = _id(model, obj.mjOBJ_HFIELD, "terrain")
        scene.terrain_shape = (int(model.hfield_nrow[scene.hfield]),
                               int(model.hfield_ncol[scene.hfield]))
        tiles_y, tiles_x = terrain.tile_grid(params.arena, params.terrain_cell)
        tile = terrain.TILE_CELLS * params.terrain_cell
        scene.terrain_origin = (-ARENA_BACK, -tiles_y * tile / 2)
        grid = [(iy, ix) for iy in range(tiles_y) for ix in range(tiles_x)]
        names = [[f"terrain_{iy}_{ix}_{lod}" for lod in ("fine", "coarse")] for iy, ix in grid]
        scene.tile_geoms = np.array([[_id(model, obj.mjOBJ_GEOM, n) for n in pair]
                                     for pair in names])
        scene.tile_hfields = np.array([[_id(model, obj.mjOBJ_HFIELD, n) for n in pair]
                                       for pair in names])
        scene.tile_origin = np.array(grid) * terrain.TILE_CELLS
        scene.tile_centres = model.geom_pos[scene.tile_geoms[:, 0], :2].copy()
        scene.terrain_materials = tuple(_id(model, obj.mjOBJ_MATERIAL, f"terrain_{i}")
                                        for i in range(len(GROUND_PALETTES)))
        # A tile maps its texture once over its extent: repeat the ground's tile.
        for mat in scene.terrain_materials:
            model.mat_texrepeat[mat] = [tile / GROUND_TILE, tile / GROUND_TILE]
    threats: list[int] = []
    owners: list[int] = []
    for i in range(params.n_obstacles):
        body = _id(model, obj.mjOBJ_BODY, f"obstacle_{i}")
        geoms = _body_geoms(model, body)
        kind = params.obstacle_kinds[i % len(params.obstacle_kinds)]
        scene.obstacles.append((body, kind, geoms))
        solid = [g for g in geoms if model.geom_contype[g]]
        threats += solid
        owners += [i] * len(solid)
    for k, name in enumerate(WALLS if params.arena_walls else ()):
        scene.wall_geoms.append(_id(model, obj.mjOBJ_GEOM, f"arena_wall_{name}"))
        threats.append(scene.wall_geoms[-1])
        owners.append(params.n_obstacles + k)
    if params.mover != "none":
        scene.mover_kind = params.mover
        scene.mover_body = _id(model, obj.mjOBJ_BODY, "mover")
        scene.mover_geoms = _body_geoms(model, scene.mover_body)
        joint = _id(model, obj.mjOBJ_JOINT, "mover")
        scene.mover_qpos_adr = int(model.jnt_qposadr[joint])
        scene.mover_dof_adr = int(model.jnt_dofadr[joint])
        solid = [g for g in scene.mover_geoms if model.geom_contype[g]]
        if params.mover == "swing":
            scene.mover_pivot = _id(model, obj.mjOBJ_BODY, "mover_pivot")
            solid += _body_geoms(model, scene.mover_pivot)
        threats += solid
        owners += [params.n_obstacles + len(scene.wall_geoms)] * len(solid)
    scene.threat_geoms = np.array(threats, dtype=int)
    scene.threat_owner = np.array(owners, dtype=int)
    scene.n_threats = params.n_obstacles + len(scene.wall_geoms) + (params.mover != "none")
    for i in range(params.scenery):
        body = _id(model, obj.mjOBJ_BODY, f"scenery_{i}")
        scene.scenery.append((body, _body_geoms(model, body)))
    if params.goal_distance > 0:
        scene.goal_body = _id(model, obj.mjOBJ_BODY, "goal")
    # Episodes move these geoms within their bodies: MuJoCo must not take the shortcut
    # of placing a geom at its body's frame (compiled for geoms created at offset 0).
    moved = [g for _b, _k, geoms in scene.obstacles for g in geoms]
    moved += scene.mover_geoms + [g for _b, geoms in scene.scenery for g in geoms]
    if scene.mover_pivot >= 0:
        moved += _body_geoms(model, scene.mover_pivot)
    model.geom_sameframe[moved] = mujoco.mjtSameFrame.mjSAMEFRAME_NONE
    return scene
