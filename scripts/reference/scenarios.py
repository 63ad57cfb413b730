"""The scenario reference, generated from the code so that it cannot drift.

`scenarios_page` writes docs/reference/scenarios.md the way Gymnasium documents its
environments: what each scenario is (its file's description and comment), its action and
observation spaces (from the environment constructed with the scenario's parameters),
reward and episode end (`JitterEnv`'s docstring, with the scenario's values), the keys of
``info`` (from a reset and a step, described by `OBSERVATION_KEYS`, `INFO_KEYS` and
`TRUTH_KEYS`) and its arguments (`EnvParams`, the catalogue's overrides). A key that the
environment returns and the code does not describe stops the generator. `scene_picture`
renders a scenario from outside. ``python -m scripts.reference`` writes both.
"""

from __future__ import annotations

import inspect
import math
import re
from collections.abc import Iterable, Sequence
from typing import Any

import cv2
import numpy as np
from gymnasium import spaces

from lgmd_sim.core.resources import envs_dir
from lgmd_sim.envs.catalogue import Scenario, params_for, scenarios
from lgmd_sim.envs.params import EnvParams

#: The picture of a scenario: its size (pixels), and the view (degrees): from behind the
#: start and to its right, looking down at an angle.
PICTURE_SIZE = (400, 640)
AZIMUTH, ELEVATION = 35.0, -40.0
#: Where the picture looks at, above the ground (m), and the least ground it spans each
#: way (m).
LOOK_HEIGHT, MIN_SPAN = 0.3, 4.0
#: Ground left around what the picture must show (m).
MARGIN = 0.5
#: Rounds of centring the picture on what it must show (each fits the distance again).
FRAMING_ROUNDS = 4
#: The close-up of the carrier: its share of the picture's sides, and its distance in
#: multiples of the carrier's reach from its centre.
INSET_SHARE, INSET_DISTANCE = 0.4, 4.0
#: The picture's episode (a fixed seed: the same picture each time).
PICTURE_SEED = 0
#: The folder of the pictures, relative to the page.
SCENES = "scenes"
REGENERATE = "python -m scripts.reference --out docs/reference"


def packaged() -> dict[str, Scenario]:
    """The scenarios of the package's catalogue (envs/), not those of ``LGMD_SIM_ENVS``."""
    return {n: sc for n, sc in scenarios().items() if sc.path.parent == envs_dir()}


# --- the page ---------------------------------------------------------------------------


def scenarios_page() -> str:
    """docs/reference/scenarios.md: the common part of every scenario, then each one.

    Raises:
        ValueError: the environment returns an observation or info key that the code
            does not describe (`OBSERVATION_KEYS`, `INFO_KEYS`, `TRUTH_KEYS`).
    """
    from lgmd_sim.envs.jitter_env import JitterEnv

    facts = {name: _facts(name) for name in packaged()}
    items = _docstring_items(JitterEnv)
    lines = [
        "# Scenarios",
        "",
        f"Generated from the code by `{REGENERATE}`; do not edit. Each scenario is a file "
        "of the catalogue (envs/*.toml: a description and overrides of the parameters "
        "below), registered with Gymnasium as `lgmd_sim/<Name>-v0`: "
        "`gym.make(id, name=value, ...)` overrides any [argument](#arguments), and "
        "`lgmd-sim envs NAME` lists a scenario's values. Each picture shows the scenario "
        f"from outside (episode seed {PICTURE_SEED}), the carrier ringed and, in a corner, "
        "close up.",
        "",
        "| scenario | carrier | what it is |",
        "|---|---|---|",
        *(f"| [{n}](#{n.lower()}) | {f['params'].carrier} | {_cell(f['scenario'].description)} |"
          for n, f in facts.items()),
        "",
        f"## Common to every scenario (`{JitterEnv.__module__}.JitterEnv`)",
        "",
        _sentence(_summary(JitterEnv)),
        "",
        "### Action space",
        "",
        _sentence(items["Action"]),
        "",
        "### Observation space",
        "",
        _sentence(items["Observation"]),
        "",
        *_observation_table(facts.values()),
        "",
        "### Reward",
        "",
        _sentence(items["Reward"]),
        "",
        "### Episode end",
        "",
        _sentence(items["Episode end"]),
        "",
        "### Info",
        "",
        _sentence(items["Info"]),
        "",
        *_info_table(facts.values()),
        "",
        "### Arguments",
        "",
        "Keyword arguments of `gym.make` (a scenario sets some of them: see its table).",
        "",
        *_arguments_table(JitterEnv),
    ]
    for name, f in facts.items():
        lines += ["", *_scenario_section(name, f)]
    return "\n".join(lines) + "\n"


def _facts(name: str) -> dict[str, Any]:
    """What the page says of scenario `name`, from its environment: the spaces as
    constructed (nothing is rendered), the info keys of a frameless reset and step."""
    from lgmd_sim.envs.jitter_env import JitterEnv

    env = JitterEnv(name)
    obs_space, action_space = env.observation_space, env.action_space
    env.close()
    env = JitterEnv(name, frame="none", ssim=True)
    try:
        _obs, reset_info = env.reset(seed=PICTURE_SEED)
        step_info = env.step(np.zeros(2, np.float32))[4]
    finally:
        env.close()
    return {"scenario": packaged()[name], "params": params_for(name, {}),
            "observation": obs_space, "action": action_space,
            "info": {**reset_info, **step_info}}


def _docstring_items(cls: type) -> dict[str, str]:
    """The top-level items (``- Head: text``) of a class docstring, by head."""
    items: dict[str, str] = {}
    head = None
    for line in inspect.cleandoc(cls.__doc__ or "").splitlines():
        match = re.match(r"- ([A-Za-z ]+): (.*)", line)
        if match:
            head = match[1]
            items[head] = match[2]
        elif head and line.startswith("  "):
            items[head] += " " + line.strip()
        else:
            head = None
    missing = {"Action", "Observation", "Reward", "Episode end", "Info"} - set(items)
    if missing:
        raise ValueError(f"{cls.__name__}'s docstring lacks the item(s) "
                         f"{', '.join(sorted(missing))} (\"- Head: text\")")
    return items


def _summary(cls: type) -> str:
    """The docstring's paragraphs before its first item."""
    text = inspect.cleandoc(cls.__doc__ or "")
    return " ".join(text.split("\n- ")[0].split())


def _args(cls: type) -> dict[str, str]:
    """The ``Args:`` entries of a class docstring, by name."""
    text = inspect.cleandoc(cls.__doc__ or "").partition("Args:\n")[2]
    args: dict[str, str] = {}
    for name, doc in re.findall(r"^    (\*{0,2}\w+): (.*(?:\n        .*)*)", text, re.M):
        args[name] = " ".join(doc.split())
    return args


def _markdown(text: str) -> str:
    """Docstring markup as Markdown: ``code`` is `code`."""
    return text.replace("``", "`")


def _sentence(text: str) -> str:
    """`text` (a docstring item, a description) as a sentence of the page."""
    text = _markdown(text)
    return text[:1].upper() + text[1:] + ("" if text.endswith(".") else ".")


def _cell(text: str) -> str:
    """`text` as a Markdown table cell."""
    return _markdown(" ".join(str(text).split())).replace("|", "\\|")


def _value(v: Any) -> str:
    """A parameter's value as Python writes it (tuples as TOML and gym.make take lists)."""
    if isinstance(v, tuple):
        return "[" + ", ".join(map(_value, v)) + "]"
    return repr(float(v)) if isinstance(v, np.floating) else repr(v)


def _number(v: float) -> str:
    return f"{float(v):.4g}"


def _bounds(box: spaces.Box) -> str:
    """A Box's bounds, runs of equal components as one: "[-1, 1] x 2"."""
    pairs = list(zip(box.low.ravel().tolist(), box.high.ravel().tolist(), strict=True))
    if len(set(pairs)) == 1:
        return f"[{_number(pairs[0][0])}, {_number(pairs[0][1])}]"
    runs: list[list[Any]] = []
    for pair in pairs:
        if runs and runs[-1][0] == pair:
            runs[-1][1] += 1
        else:
            runs.append([pair, 1])
    return ", ".join(f"[{_number(lo)}, {_number(hi)}]" + (f" x {n}" if n > 1 else "")
                     for (lo, hi), n in runs)


def _box(box: spaces.Space) -> str:
    if not isinstance(box, spaces.Box):
        raise ValueError(f"the scenario reference describes Box spaces only, got {box}")
    return f"{box.dtype} {box.shape} in {_bounds(box)}"


def _kind(v: Any) -> str:
    """The type of an info value as the page says it: "float", "float64 (3,)"."""
    if isinstance(v, np.ndarray):
        return f"{v.dtype} {v.shape}"
    return type(v).__name__


def _described(keys: Iterable[str], docs: dict[str, str], what: str) -> list[str]:
    """`keys` in the order of `docs`, the code's descriptions of the `what` keys.

    Raises:
        ValueError: a key that `docs` does not describe.
    """
    keys = set(keys)
    undescribed = sorted(keys - set(docs))
    if undescribed:
        raise ValueError(f"{what} key(s) {', '.join(undescribed)} have no description: add "
                         f"them where the code describes its {what} keys")
    return [k for k in docs if k in keys]


def _observation_table(facts: Sequence[dict[str, Any]]) -> list[str]:
    from lgmd_sim.envs.jitter_env import OBSERVATION_KEYS

    seen: dict[str, spaces.Space] = {}
    for f in facts:
        seen.update(f["observation"].spaces)
    rows = [f"| `{k}` | {seen[k].dtype} | {_bounds(seen[k])} | {_cell(OBSERVATION_KEYS[k])} |"
            for k in _described(seen, OBSERVATION_KEYS, "observation")]
    return ["| key | dtype | bounds | what it holds |", "|---|---|---|---|", *rows]


def _info_docs() -> dict[str, str]:
    from lgmd_sim.envs.jitter_env import INFO_KEYS
    from lgmd_sim.world.core import TRUTH_KEYS

    return {**TRUTH_KEYS, **INFO_KEYS}


def _info_table(facts: Sequence[dict[str, Any]]) -> list[str]:
    docs = _info_docs()
    seen: dict[str, Any] = {}
    for f in facts:
        seen.update(f["info"])
    rows = [f"| `{k}` | {_kind(seen[k])} | {_cell(docs[k])} |"
            for k in _described(seen, docs, "info")]
    return ["| key | type | what it holds |", "|---|---|---|", *rows]


def _arguments_table(cls: type) -> list[str]:
    """The environment's own keyword arguments, then every parameter of `EnvParams`."""
    args = _args(cls)
    own = [p for p in inspect.signature(cls.__init__).parameters.values()
           if p.name not in ("self", "scenario") and p.kind is not p.VAR_KEYWORD]
    rows = [f"| `{p.name}` | `{_value(p.default)}` | {_cell(args[p.name])} |" for p in own]
    rows += [f"| `{name}` | `{_value(default)}` | {_cell(doc)} |"
             for name, default, _source, doc in EnvParams.describe()]
    return ["| argument | default | what it sets |", "|---|---|---|", *rows]


def _comment(sc: Scenario) -> str:
    """The comment that opens the scenario's file: what it is for, in its author's words."""
    lines = []
    for line in sc.path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    return " ".join(" ".join(lines).split())


def _reward(p: EnvParams, has_goal: bool) -> str:
    """The scenario's reward per step, with its values."""
    terms = [f"+{_number(p.progress_reward)} per metre towards the goal"] if has_goal else []
    terms += [f"-{_number(p.collision_penalty)} on a collision",
              f"-{_number(p.effort_penalty)} x the squared action norm"]
    shaping = [(p.goal_bonus, "+{} on reaching the goal", has_goal),
               (p.time_penalty, "-{} per second", True),
               (p.proximity_penalty, "-{} per second in the Oracle's trigger zone", True)]
    terms += [text.format(_number(v)) for v, text, applies in shaping if v and applies]
    return "; ".join(terms)


def _episode_end(p: EnvParams, has_goal: bool) -> str:
    ends = (["a collision"] if p.terminate_on_collision else [])
    ends += [f"reaching the goal (within {_number(p.goal_radius)} m)"] if has_goal else []
    terminated = f"terminated on {' or on '.join(ends)}; " if ends else "never terminated; "
    return terminated + f"truncated after {_number(p.time_limit)} s ({p.max_steps} steps)"


def _scenario_section(name: str, f: dict[str, Any]) -> list[str]:
    sc, p = f["scenario"], f["params"]
    has_goal = p.goal_distance > 0
    observation = "<br>".join(f"`{k}`: {_box(s)}" for k, s in f["observation"].spaces.items())
    info = ", ".join(f"`{k}`" for k in _described(f["info"], _info_docs(), "info")
                     if k != "ssim")
    described = {n: (default, doc) for n, default, _s, doc in EnvParams.describe()}
    overrides = [f"| `{k}` | `{_value(getattr(p, k))}` | `{_value(described[k][0])}` | "
                 f"{_cell(described[k][1])} |" for k in sc.overrides]
    return [
        f"## {name}",
        "",
        f"![{name} from outside]({SCENES}/{name}.png)",
        "",
        f"**{_sentence(sc.description)}** {_markdown(_comment(sc))}".rstrip(),
        "",
        "| | |",
        "|---|---|",
        f"| make | `gym.make(\"{sc.env_id}\")` |",
        f"| file | envs/{sc.path.name} |",
        f"| carrier | {p.carrier}, jitter {_number(p.jitter)} |",
        f"| action space | `action`: {_box(f['action'])} |",
        f"| observation space | {observation} |",
        f"| reward | {_cell(_reward(p, has_goal))} |",
        f"| episode end | {_cell(_episode_end(p, has_goal))} |",
        f"| info | {info}; `ssim` with `ssim=True` |",
        "",
        "Set by the scenario (every other argument at its default):",
        "",
        "| argument | value | default | what it sets |",
        "|---|---|---|---|",
        *overrides,
    ]


# --- the picture ------------------------------------------------------------------------


def scene_picture(name: str, height: int = PICTURE_SIZE[0], width: int = PICTURE_SIZE[1],
                  seed: int = PICTURE_SEED) -> np.ndarray:
    """Scenario `name` seen from outside, RGB (height, width, 3) uint8.

    A free camera behind the start and to its right looks down at an angle at everything
    the scenario places (the carrier, the rough patch, the obstacles, the arena walls, the
    goal, the mover half-way along its approach); the carrier is ringed and shown close
    up in the corner that hides least of them. Scenery between the camera and the scene
    is left out. Episode `seed`, rendered offscreen (no
    frames of the carrier's camera are rendered).
    """
    from lgmd_sim.envs.jitter_env import JitterEnv
    from lgmd_sim.world.pieces import HIDDEN

    env = JitterEnv(name, frame="none")
    try:
        env.reset(seed=seed)
        p = env.params
        if p.mover != "none":  # half-way: the mover in the scene, not at its far start
            for _ in range(round(p.mover_distance / p.mover_speed / 2 * p.fps)):
                env.step(np.zeros(2, np.float32))
        world = env.world
        m, d, sc = world.model, world.data, world.scene
        # The world draws the terrain tiles its camera sees; from outside, all of them.
        m.geom_group[sc.tile_geoms[:, 0]] = 0
        m.vis.global_.offheight = max(m.vis.global_.offheight, height)
        m.vis.global_.offwidth = max(m.vis.global_.offwidth, width)
        m.vis.quality.shadowsize = 4096
        m.vis.quality.offsamples = 4  # smooth edges: a picture, not a detector's input
        fovy = math.radians(m.vis.global_.fovy)
        forward, right, up = _axes(AZIMUTH, ELEVATION)
        lookat, distance = _frame(*_extent(world), (forward, right, up), fovy, width / height)
        eye = lookat - distance * forward
        for body, geoms in sc.scenery:  # in front of the scene: would hide it
            if np.linalg.norm(d.xpos[body] - eye) < distance:
                m.geom_group[geoms] = HIDDEN
        carrier = _carrier_geoms(m, sc.carrier_body)
        centre = d.xpos[sc.carrier_body]
        reach = max(float(np.linalg.norm(d.geom_xpos[g] - centre) + m.geom_rbound[g])
                    for g in carrier)
        focus = d.geom_xpos[carrier].mean(axis=0)
        subjects = np.vstack([focus, d.geom_xpos[sc.threat_geoms],
                              d.xpos[[sc.goal_body] if sc.goal_body >= 0 else []]])
        image = _render(m, d, height, width, lookat, distance)
        ih, iw = round(height * INSET_SHARE), round(width * INSET_SHARE)
        inset = _render(m, d, ih, iw, focus, INSET_DISTANCE * reach)
    finally:
        env.close()
    # where the camera sees the carrier and what it meets: a pinhole projection
    q = subjects - eye
    scale = height / 2 / math.tan(fovy / 2) / (q @ forward)
    u, v = width / 2 + scale * (q @ right), height / 2 - scale * (q @ up)
    radius = max(height // 25, round(scale[0] * reach * 2))  # seen at any distance
    cv2.circle(image, (round(u[0]), round(v[0])), radius, (255, 255, 255),
               max(1, height // 200), cv2.LINE_AA)
    top, left = _clearest_corner(u, v, (height, width), (ih, iw))
    image[max(top - 2, 0):top + ih + 2, max(left - 2, 0):left + iw + 2] = 255  # its frame
    image[top:top + ih, left:left + iw] = inset
    return image


def _clearest_corner(u: np.ndarray, v: np.ndarray, size: tuple[int, int],
                     inset: tuple[int, int]) -> tuple[int, int]:
    """The (top, left) of the corner of a picture of `size` where a close-up of size
    `inset` stays farthest from the points (u, v) (pixels): it hides none of them if it
    can. Bottom left first, where a view from behind the start shows bare ground most."""
    (height, width), (ih, iw) = size, inset
    best: tuple[float, int, int] | None = None
    for top, left in ((height - ih, 0), (0, 0), (height - ih, width - iw), (0, width - iw)):
        du = np.maximum(0, np.maximum(left - u, u - (left + iw)))
        dv = np.maximum(0, np.maximum(top - v, v - (top + ih)))
        clearance = float(np.hypot(du, dv).min())
        if best is None or clearance > best[0]:
            best = (clearance, top, left)
    return best[1], best[2]


def _axes(azimuth: float, elevation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward, right and up of MuJoCo's free camera at `azimuth`, `elevation` (deg)."""
    a, e = math.radians(azimuth), math.radians(elevation)
    forward = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    right = np.array([math.sin(a), -math.cos(a), 0.0])
    return forward, right, np.cross(right, forward)


def _frame(lo: np.ndarray, hi: np.ndarray, top: float,
           axes: tuple[np.ndarray, np.ndarray, np.ndarray], fovy: float, aspect: float
           ) -> tuple[np.ndarray, float]:
    """Where a camera with `axes` (forward, right, up) and vertical field of view `fovy`
    (rad) looks, and from how far, to see the box from `lo` to `hi` on the ground and
    `top` high whole and centred: (look-at point, distance)."""
    forward, right, up = axes
    tan_v = math.tan(fovy / 2)
    tan_h = tan_v * aspect
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (0.0, top)])
    lookat = np.array([*(lo + hi) / 2, LOOK_HEIGHT])
    for _ in range(FRAMING_ROUNDS):  # the nearer side looks larger: centre, fit again
        q = corners - lookat
        # each corner's depth, q . forward + distance, must hold its offsets in view
        distance = float(np.max(np.maximum(np.abs(q @ right) / tan_h, np.abs(q @ up) / tan_v)
                                - q @ forward))
        depth = q @ forward + distance
        x, y = (q @ right) / depth / tan_h, (q @ up) / depth / tan_v  # in [-1, 1]
        shift = (x.max() + x.min()) / 2 * tan_h * right + (y.max() + y.min()) / 2 * tan_v * up
        lookat = lookat + distance * shift
    return lookat, distance


def _extent(world) -> tuple[np.ndarray, np.ndarray, float]:  # world: JitterWorld
    """The box a picture must show: corners (x, y) of the ground under the carrier, the
    obstacles and walls, the goal, the mover and the rough patch, with `MARGIN` around
    them, and the height of the tallest of them (m)."""
    m, d, sc = world.model, world.data, world.scene
    view = world.top_view()
    points = [d.xpos[sc.carrier_body, :2]]
    for footprint in view["obstacles"]:
        if "polygon" in footprint:
            points += list(np.array(footprint["polygon"]))
        else:
            x, y, r = footprint["circle"]
            points += [np.array([x - r, y - r]), np.array([x + r, y + r])]
    if view["goal"] is not None:
        points.append(np.array(view["goal"]))
    if "extent" in view:  # the rough patch
        x0, x1, y0, y1 = view["extent"]
        points += [np.array([x0, y0]), np.array([x1, y1])]
    if sc.mover_body >= 0:
        points.append(d.xpos[sc.mover_body, :2])
    points = np.array(points)
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    half = np.maximum((points.max(axis=0) - points.min(axis=0)) / 2 + MARGIN, MIN_SPAN / 2)
    shown = np.concatenate([sc.threat_geoms, _carrier_geoms(m, sc.carrier_body),
                            np.flatnonzero(m.geom_bodyid == sc.goal_body)])
    top = float(np.max(d.geom_xpos[shown, 2] + m.geom_rbound[shown]))
    return centre - half, centre + half, top


def _carrier_geoms(m, body: int) -> np.ndarray:  # m: mujoco.MjModel
    """The geoms of the carrier (its body and those attached to it, wheels included)."""
    return np.flatnonzero(m.body_rootid[m.geom_bodyid] == m.body_rootid[body])


def _render(m, d, height: int, width: int, lookat: np.ndarray, distance: float
            ) -> np.ndarray:
    """A free camera's view (`AZIMUTH`, `ELEVATION`) of `lookat` from `distance`, with
    shadows and the carrier's camera housing (drawn by no carrier camera) shown."""
    from lgmd_sim.world.gl import mujoco

    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = lookat
    camera.distance = distance
    camera.azimuth, camera.elevation = AZIMUTH, ELEVATION
    option = mujoco.MjvOption()
    option.sitegroup[:] = 0  # sensor sites are not part of the world
    option.geomgroup[3] = 1  # the camera housing
    with mujoco.Renderer(m, height, width) as renderer:
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = True
        renderer.update_scene(d, camera, option)
        return renderer.render().copy()
