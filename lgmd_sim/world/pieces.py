"""The pieces a jitter world's MuJoCo model is made of, each added to an ``MjSpec`` by
`lgmd_sim.world.scene.build`: the physics and visual options (`set_options`), the
textures and materials (`add_assets`), the rough terrain (`add_terrain`), the carrier
(`add_carrier`), the static obstacles, the arena walls, the moving object and the scenery.

What changes between episodes (sizes, positions, colours, terrain heights) is left at
placeholders here: `lgmd_sim.world.randomise` writes it per episode. The names given
here, and the order of each piece's geoms, are what `lgmd_sim.world.scene` finds the ids
by.
"""

from __future__ import annotations

import functools

import numpy as np

from lgmd_sim.core.resources import assets_dir
from lgmd_sim.world import terrain
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import ARENA_BACK, SceneParams

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


def set_options(spec: mujoco.MjSpec, params: SceneParams) -> None:
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


def add_terrain(spec: mujoco.MjSpec, params: SceneParams) -> None:
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


def add_assets(spec: mujoco.MjSpec) -> None:
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
        # set when the compiled model is indexed (lgmd_sim.world.scene), once its size is
        # known.
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


def add_carrier(spec: mujoco.MjSpec, params: SceneParams) -> None:
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


def add_obstacle(spec: mujoco.MjSpec, name: str, kind: str) -> None:
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


def add_arena_walls(spec: mujoco.MjSpec, params: SceneParams) -> None:
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


def add_mover(spec: mujoco.MjSpec, kind: str) -> None:
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


def add_scenery(spec: mujoco.MjSpec, name: str, *, tree: bool) -> None:
    body = spec.worldbody.add_body(name=name)
    G = mujoco.mjtGeom
    if tree:
        _geom(body, f"{name}/trunk", G.mjGEOM_CYLINDER, collide=False, rgba=[0.4, 0.3, 0.2, 1])
        _geom(body, f"{name}/crown", G.mjGEOM_ELLIPSOID, collide=False,
              material="obstacle_blotches")
    else:
        _geom(body, f"{name}/block", G.mjGEOM_BOX, collide=False, material="obstacle_stripes")
        _geom(body, f"{name}/roof", G.mjGEOM_BOX, collide=False)
