"""Build the MuJoCo model of a jitter world from its parameters.

The model's structure (which bodies and geoms exist) depends only on the parameters, so
one compiled model serves every episode of an environment: `lgmd_sim.world.randomise`
seeds each episode by writing positions, sizes, colours, materials, light and terrain
heights into the model in place. The layout: the carrier starts at the origin heading
along +x; the rough terrain patch (a heightfield) spans `arena` from 2 m behind the start
and blends into a flat ground plane; the arena walls (if any) stand around its edges; the
goal (if any) lies straight ahead.

The pieces the model is made of are added by `lgmd_sim.world.pieces`; `build` compiles
them and indexes the compiled model (`Scene`: the ids the world drives and observes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lgmd_sim.world import terrain
from lgmd_sim.world.gl import mujoco
from lgmd_sim.world.params import ARENA_BACK, SceneParams
from lgmd_sim.world.pieces import (
    BIT_WORLD,
    GROUND_PALETTES,
    GROUND_TILE,
    OBSTACLE_TEXTURES,
    PREFIX,
    WALLS,
    add_arena_walls,
    add_assets,
    add_carrier,
    add_mover,
    add_obstacle,
    add_scenery,
    add_terrain,
    set_options,
)

#: Side of the flat ground plane (m): far beyond anything the camera resolves. It is drawn
#: as 2 x 2 quads (the third plane size is the render grid spacing): a fine grid costs
#: more than the rest of a frame on software GL.
GROUND_SIZE = 200.0


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
    # Static obstacles: body id, kind, and geom ids in the order documented in
    # `lgmd_sim.world.pieces.add_obstacle`.
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
    set_options(spec, params)
    add_assets(spec)
    world = spec.worldbody
    world.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE,
                   size=[GROUND_SIZE / 2, GROUND_SIZE / 2, GROUND_SIZE / 4],
                   material="ground_0", contype=BIT_WORLD, conaffinity=BIT_WORLD)
    if params.resolved_roughness > 0:
        add_terrain(spec, params)
    # The sun (its direction is seeded per episode); the headlight is the sky.
    world.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                    dir=[0, 0, -1], diffuse=[0.7, 0.7, 0.66], specular=[0.2, 0.2, 0.2],
                    ambient=[0.1, 0.1, 0.12], castshadow=params.shadows)
    add_carrier(spec, params)
    for i in range(params.n_obstacles):
        add_obstacle(spec, f"obstacle_{i}", params.obstacle_kinds[i % len(params.obstacle_kinds)])
    if params.arena_walls:
        add_arena_walls(spec, params)
    if params.mover != "none":
        add_mover(spec, params.mover)
    for i in range(params.scenery):
        add_scenery(spec, f"scenery_{i}", tree=i % 3 != 2)
    if params.goal_distance > 0:
        goal = world.add_body(name="goal", pos=[params.goal_distance, 0, 0])
        goal.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0.6], pos=[0, 0, 0.6],
                      rgba=[0.9, 0.9, 0.9, 1], contype=0, conaffinity=0)
        goal.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.005, 0.18, 0.12],
                      pos=[0, 0.18, 1.05], rgba=[0.1, 0.8, 0.2, 1], contype=0, conaffinity=0)
    model = spec.compile()
    return _index(model, params)


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
