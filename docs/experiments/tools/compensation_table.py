"""Ego-motion compensation, open loop: every model with every front end on the same clips.

Runs the clips (the carrier driving straight, as `lgmd-sim record` does) of these groups,
each on held-out seeds, and every model (default preset) on each with each front end
(`lgmd_sim.models.stabilize`; the motion is computed once per clip and front end and fed
to every model, as a model built with that front end computes it):

- jitter: HandheldApproach and MutualApproach at jitter 1 and 1.5;
- stationary: StationaryApproach, and HandheldApproach / MutualApproach at jitter 0;
- near miss: PassBy (a passing car, with its passing shade) at jitter 0 and 1;
- robot: RoughTerrainObstacles at jitter 0, 1 and 2, with the ground's own flow removed
  too ("+ground": the plane-induced homography below the horizon; "pose+ground" takes the
  camera's displacement, the ground's normal and the camera's height above it from the
  pose, "image+ground" the rotation from the image fit, the displacement from wheel
  odometry and the robot's mounting (ground normal along the camera's y, the camera's
  height at the start); "+horizon": below the horizon silenced);
- brightness: StationaryApproach and HandheldApproach (jitter 1) with light flicker.

The world's IMU has a MEMS gyro's noise and bias here (`GYRO`), so "imu" differs from
"pose". A clip's record is stored in OUT as it finishes; a second run resumes. Prints the
tables (Markdown) and writes them to OUT/tables.md; ``--figure`` draws the main one.

    python docs/experiments/tools/compensation_table.py --out runs/compensation \
        --figure docs/stabilize/table.png --layers-figure docs/stabilize/p_layers.png
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from collections import defaultdict
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

#: A MEMS gyro (Bosch BMI088 datasheet): noise density and zero-rate offset (deg/s).
GYRO = {"gyro_noise": 0.014, "gyro_bias": 1.0}
#: The light flicker of the brightness group (relative amplitude).
FLICKER = {"flicker": 0.3}
#: Alarms in the last LATE share of the approach (and before the collision) are late hits.
LATE = 0.15
#: A jitter clip behaves like its unshaken twin when their SI differ by at most this.
TWIN_SI = 0.05
FRONTS = ["none", "pose", "imu", "image", "gain", "image+gain"]
ROBOT_FRONTS = ["none", "pose", "imu", "image", "pose+ground", "pose+horizon", "image+ground"]
GROUPS = {
    "jitter": [("HandheldApproach", 1.0, {}), ("HandheldApproach", 1.5, {}),
               ("MutualApproach", 1.0, {}), ("MutualApproach", 1.5, {})],
    "stationary": [("StationaryApproach", 0.0, {}), ("HandheldApproach", 0.0, {}),
                   ("MutualApproach", 0.0, {})],
    "near miss": [("PassBy", 0.0, {}), ("PassBy", 1.0, {})],
    "robot": [("RoughTerrainObstacles", 0.0, {}), ("RoughTerrainObstacles", 1.0, {}),
              ("RoughTerrainObstacles", 2.0, {})],
    "brightness": [("StationaryApproach", 0.0, FLICKER), ("HandheldApproach", 1.0, FLICKER)],
}


def clip_key(scenario: str, jitter: float, extra: dict, seed: int) -> str:
    tail = "".join(f"-{k}{v:g}" for k, v in sorted(extra.items()))
    return f"{scenario}-j{jitter:g}{tail}-s{seed}"


# --- one clip ---------------------------------------------------------------------------------


def _episode(scenario: str, jitter: float, extra: dict, seed: int, resolution: Any) -> dict:
    """Grey frames, the rotation sources, the camera's poses, odometry and heights above
    the ground of one clip."""
    import cv2
    import gymnasium as gym

    from lgmd_sim.controllers import Straight, rollout
    from lgmd_sim.envs.catalogue import scenario as find

    env = gym.make(find(scenario).env_id, jitter=jitter, resolution=resolution, **GYRO, **extra)
    try:
        steps = list(rollout(env, Straight(), seed=seed))
        world = env.unwrapped.world
        fps = env.unwrapped.params.fps
        pos = np.array([s.info["camera_pos"] for s in steps])
        height = pos[:, 2] - world.ground_height(pos[:, 0], pos[:, 1])
        wheel = world.scene.wheel_radius
    finally:
        env.close()
    info = [s.info for s in steps]
    hit = info[-1]["first_collision_frame"]
    return {
        "pos": pos, "quat": np.array([i["camera_quat"] for i in info]), "height": height,
        "grey": [cv2.cvtColor(s.obs["frame"], cv2.COLOR_RGB2GRAY) for s in steps],
        "pose": np.array([i["pose_rotation"] for i in info]),
        "imu": np.array([i["imu_rotation"] for i in info]),
        "angvel": np.array([i["camera_angvel"] for i in info]) / fps,
        # wheel odometry: the distance driven over each frame, along the camera's view
        "forward": np.array([s.obs["proprio"][:2].mean() for s in steps]) * wheel / fps,
        "collision": int(hit) if hit >= 0 else None,
    }


def _ground_geometry(ep: dict, t: int, source: str) -> tuple[np.ndarray, np.ndarray, float]:
    """The camera's displacement over frame t and the ground's upward normal, both in the
    previous camera's frame, and the camera's height above the ground: from the pose, or
    (otherwise) from wheel odometry and the robot's mounting."""
    if source != "pose":
        return np.array([0.0, 0.0, -ep["forward"][t]]), np.array([0.0, 1.0, 0.0]), float(
            ep["height"][0])
    import mujoco

    world_from_cam = np.empty(9)
    mujoco.mju_quat2Mat(world_from_cam, ep["quat"][t - 1])
    cam = world_from_cam.reshape(3, 3).T
    return cam @ (ep["pos"][t] - ep["pos"][t - 1]), cam[:, 2], float(ep["height"][t - 1])


def _motions(ep: dict, front: str, fovy: float) -> tuple[list, np.ndarray | None]:
    """Per frame the `Motion` of a front end (None on frame 0 and for "none"), and, for
    "image", the rotations it found."""
    from lgmd_sim.models.stabilize import FrontEnd, ground_motion, intrinsics
    from lgmd_sim.models.warp import Motion

    source, _, ground = front.partition("+")
    if front == "none":
        return [None] * len(ep["grey"]), None
    if source == "gain" or ground == "gain":
        ground = ""
    fe = FrontEnd(SimpleNamespace(stabilize=source if source != "gain" else "none",
                                  fovy=fovy, gain="gain" in front), 1)
    k = intrinsics(fovy, *ep["grey"][0].shape)
    out, found = [], []
    for t, grey in enumerate(ep["grey"]):
        rotation = ep[source][t] if source in ("pose", "imu") else None
        m = fe.motion(grey[None], rotation)
        found.append(fe.rotations[0].copy())
        if ground and t > 0:
            turn = ep["pose"][t] if source == "pose" else fe.rotations[0]
            h, horizon, g = ground_motion(turn, *_ground_geometry(ep, t, source), k)
            m = Motion(h, horizon=horizon, ground=g if ground == "ground" else None)
        out.append(None if t == 0 else m)
    return out, np.array(found) if source == "image" else None


def _angle_error(a: np.ndarray, b: np.ndarray) -> float:
    """Mean angle (degrees) between the rotations a and b, frames 1 on."""
    from lgmd_sim.models.stabilize import rotation_matrix, rotation_vector

    rel = [rotation_vector(x.T @ y) for x, y in zip(rotation_matrix(a[1:]),
                                                    rotation_matrix(b[1:]), strict=True)]
    return float(np.degrees(np.linalg.norm(rel, axis=1)).mean())


def run_clip(scenario: str, jitter: float, extra: dict, seed: int, resolution: Any,
             names: list[str], fronts: list[str], fovy: float = 55.0) -> dict:
    """Every model with every front end on one clip: first alarms and potentials."""
    from lgmd_sim import models

    ep = _episode(scenario, jitter, extra, seed, resolution)
    record: dict[str, Any] = {
        "scenario": scenario, "jitter": jitter, "extra": extra, "seed": seed,
        "frames": len(ep["grey"]), "collision": ep["collision"],
        "rotation_deg": float(np.degrees(np.linalg.norm(ep["pose"][1:], axis=1)).mean()),
        "error_deg": {"imu": _angle_error(ep["imu"], ep["pose"]),
                      "angvel": _angle_error(ep["angvel"], ep["pose"])},
        "runs": defaultdict(dict),
    }
    for front in fronts:
        motions, found = _motions(ep, front, fovy)
        if found is not None and front == "image":
            record["error_deg"]["image"] = _angle_error(found, ep["pose"])
        for name in names:
            m = models.make(name)
            pot = np.array([m.step(g, motion=mo).potential for g, mo in zip(ep["grey"], motions,
                                                                              strict=True)])
            alarm = np.flatnonzero(pot > m.params.threshold)
            record["runs"][name][front] = {
                "first_alarm": int(alarm[0]) if alarm.size else None,
                "potential": np.round(pot, 4).tolist()}
    return record


# --- tables -------------------------------------------------------------------------------------


def _si(first: int | None, frames: int) -> float:
    return 1.0 if first is None else (first + 1) / frames


def _late(first: int | None, collision: int | None) -> bool:
    return (first is not None and collision is not None
            and (1.0 - LATE) * collision <= first < collision)


def _before(first: int | None, collision: int | None) -> bool:
    return first is not None and collision is not None and first < collision


def _share(flags: list[bool]) -> str:
    return f"{np.mean(flags):.0%} ({sum(flags)}/{len(flags)})" if flags else "-"


def _in_group(rec: dict, group: str) -> bool:
    return any(rec["scenario"] == s and rec["jitter"] == j and rec["extra"] == e
               for s, j, e in GROUPS[group])


def main_table(records: list[dict], names: list[str]) -> str:
    """Per model and front end: jitter clips alarming late (and before the collision),
    their mean SI and how many behave like their unshaken twin; stationary clips alarming
    before the collision; near misses alarming."""
    si = {(r["scenario"], r["seed"], m, f): _si(r["runs"][m][f]["first_alarm"], r["frames"])
          for r in records if r["jitter"] == 0 and not r["extra"] for m in r["runs"]
          for f in r["runs"][m]}
    lines = ["| model | front end | jitter: late hit | jitter: mean SI | jitter: like its "
             "unshaken twin | stationary: alarm before collision | near miss: alarm |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for name in names:
        for front in FRONTS:
            jit = [r for r in records if _in_group(r, "jitter") and front in r["runs"][name]]
            sta = [r for r in records if _in_group(r, "stationary")
                   and front in r["runs"][name]]
            near = [r for r in records if _in_group(r, "near miss")
                    and front in r["runs"][name]]
            if not jit:
                continue
            first = [r["runs"][name][front]["first_alarm"] for r in jit]
            sis = [_si(a, r["frames"]) for a, r in zip(first, jit, strict=True)]
            twins = [abs(s - si[(r["scenario"], r["seed"], name, front)]) <= TWIN_SI
                     for s, r in zip(sis, jit, strict=True)
                     if (r["scenario"], r["seed"], name, front) in si]
            lines.append(
                f"| {name} | {front} | "
                f"{_share([_late(a, r['collision']) for a, r in zip(first, jit, strict=True)])} "
                f"| {np.mean(sis):.2f} | {_share(twins)} | "
                f"{_share([_before(r['runs'][name][front]['first_alarm'], r['collision']) for r in sta])} | "  # noqa: E501
                f"{_share([r['runs'][name][front]['first_alarm'] is not None for r in near])} |")
    return "\n".join(lines) + "\n"


def robot_table(records: list[dict], names: list[str]) -> str:
    """Per model and front end, the robot at each jitter level: late hits, mean SI."""
    robot = [r for r in records if _in_group(r, "robot")]
    levels = sorted({r["jitter"] for r in robot})
    head = " | ".join(f"jitter {j:g}: late hit | jitter {j:g}: mean SI" for j in levels)
    lines = [f"| model | front end | {head} |", "|---|---|" + "---:|---:|" * len(levels)]
    for name in names:
        for front in ROBOT_FRONTS:
            cells = []
            for j in levels:
                clips = [r for r in robot if r["jitter"] == j and front in r["runs"][name]]
                first = [r["runs"][name][front]["first_alarm"] for r in clips]
                cells += [_share([_late(a, r["collision"]) for a, r in zip(first, clips,
                                                                           strict=True)]),
                          f"{np.mean([_si(a, r['frames']) for a, r in zip(first, clips, strict=True)]):.2f}"  # noqa: E501
                          if clips else "-"]
            lines.append(f"| {name} | {front} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def brightness_table(records: list[dict], names: list[str]) -> str:
    """With and without the gain: flickering light (a collision each) and the passing
    shade of the near misses."""
    groups = [(f"{s} j{j:g}, flicker {e['flicker']:g}", lambda r, s=s, j=j, e=e: (
        r["scenario"] == s and r["jitter"] == j and r["extra"] == e))
              for s, j, e in GROUPS["brightness"]]
    groups.append(("PassBy j0, shade (near miss)", lambda r: (
        r["scenario"] == "PassBy" and r["jitter"] == 0 and not r["extra"])))
    lines = ["| clips | model | front end | late hit | alarm before collision | alarm | mean SI |",
             "|---|---|---|---:|---:|---:|---:|"]
    for label, keep in groups:
        clips = [r for r in records if keep(r)]
        for name in names:
            for front in ("none", "gain", "image", "image+gain"):
                runs = [(r, r["runs"][name][front]["first_alarm"]) for r in clips
                        if front in r["runs"][name]]
                if not runs:
                    continue
                lines.append(
                    f"| {label} | {name} | {front} | "
                    f"{_share([_late(a, r['collision']) for r, a in runs])} | "
                    f"{_share([_before(a, r['collision']) for r, a in runs])} | "
                    f"{_share([a is not None for _r, a in runs])} | "
                    f"{np.mean([_si(a, r['frames']) for r, a in runs]):.2f} |")
    return "\n".join(lines) + "\n"


def rotation_table(records: list[dict]) -> str:
    """Mean error of each rotation source against the pose, per scenario."""
    lines = ["| clips | n | camera turn per frame (deg) | IMU error (deg) | image fit error "
             "(deg) | angular velocity x frame time, error (deg) |",
             "|---|---:|---:|---:|---:|---:|"]
    rows: dict[str, list[dict]] = defaultdict(list)
    for r in records:
        if r["jitter"] > 0 and not r["extra"]:
            rows[f"{r['scenario']} j{r['jitter']:g}"].append(r)
    for label in sorted(rows):
        rs = rows[label]
        image = [r["error_deg"]["image"] for r in rs if "image" in r["error_deg"]]
        lines.append(
            f"| {label} | {len(rs)} | {np.mean([r['rotation_deg'] for r in rs]):.3f} | "
            f"{np.mean([r['error_deg']['imu'] for r in rs]):.3f} | "
            f"{np.mean(image) if image else float('nan'):.3f} | "
            f"{np.mean([r['error_deg']['angvel'] for r in rs]):.3f} |")
    return "\n".join(lines) + "\n"


def figure(records: list[dict], names: list[str], path: Path) -> None:
    """Bars: per model and front end, the share of jitter clips alarming late and of
    stationary clips alarming before the collision."""
    from lgmd_sim.core.plots import figure as new_figure

    fig = new_figure(figsize=(11, 4.2))
    axes = fig.subplots(1, 2, sharey=True)
    width = 0.8 / len(FRONTS)
    for ax, group, judge, title in (
            (axes[0], "jitter", _late, "jitter clips: alarm in the last 15% (late hit)"),
            (axes[1], "stationary", _before, "stationary clips: alarm before collision")):
        for k, front in enumerate(FRONTS):
            shares = []
            for name in names:
                runs = [r for r in records if _in_group(r, group)]
                shares.append(np.mean([judge(r["runs"][name][front]["first_alarm"],
                                             r["collision"]) for r in runs]))
            ax.bar(np.arange(len(names)) + (k - (len(FRONTS) - 1) / 2) * width, shares,
                   width, label=front)
        ax.set_xticks(np.arange(len(names)), names)
        ax.set_title(title, fontsize="medium")
        ax.set_ylim(0, 1.05)
    axes[0].set_ylabel("share of clips")
    axes[1].legend(title="front end", fontsize="small", loc="upper left",
                   bbox_to_anchor=(1.0, 1.0))
    fig.savefig(path, dpi=110)


#: The clips and frames of the P-layer figure: (scenario, jitter, seed, share of the clip).
LAYER_CLIPS = [("HandheldApproach", 1.0, 12, 0.6), ("RoughTerrainObstacles", 1.0, 12, 0.5)]


def layers_figure(path: Path, resolution: Any, fovy: float = 55.0) -> None:
    """What is left after compensation: LGMD1's |P| on one frame of a hand-held and a
    robot clip without a front end, with the camera's rotation removed (pose) and with
    the ground plane's flow removed too (pose+ground)."""
    from lgmd_sim import models
    from lgmd_sim.core.plots import figure as new_figure

    fronts = ["none", "pose", "pose+ground"]
    fig = new_figure(figsize=(13, 2.2 * len(LAYER_CLIPS) + 0.4))
    axes = fig.subplots(len(LAYER_CLIPS), 1 + len(fronts), squeeze=False)
    for row, (scenario, jitter, seed, share) in enumerate(LAYER_CLIPS):
        ep = _episode(scenario, jitter, {}, seed, resolution)
        t = int(share * (len(ep["grey"]) - 1))
        axes[row, 0].imshow(ep["grey"][t], cmap="gray", vmin=0, vmax=255)
        axes[row, 0].set_title(f"{scenario} j{jitter:g} s{seed}, frame {t}", fontsize="small")
        for col, front in enumerate(fronts, start=1):
            m = models.make("lgmd1")
            for grey, motion in zip(ep["grey"][:t + 1], _motions(ep, front, fovy)[0],
                                    strict=False):
                out = m.step(grey, motion=motion, layers=True)
            p = np.abs(out.layers["P"])
            axes[row, col].imshow(p, cmap="magma", vmin=0, vmax=40)
            axes[row, col].set_title(f"|P|, {front}: mean {p.mean():.2f}, K {out.potential:.2f}",
                                     fontsize="small")
    for ax in axes.flat:
        ax.axis("off")
    fig.savefig(path, dpi=100)


# --- the run ------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    from lgmd_sim import models
    from lgmd_sim.core.fileio import write_text_atomic

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="run folder (resumed when it exists)")
    ap.add_argument("--seeds", default="10:18", help="FIRST:STOP (default 10:18, held out)")
    ap.add_argument("--resolution", default="paper", help="paper (default), rl, small")
    ap.add_argument("--groups", default=",".join(GROUPS), help="comma-separated groups")
    ap.add_argument("--models", default="all", help="comma-separated names, or all")
    ap.add_argument("--figure", help="also draw the main table as a figure (PNG)")
    ap.add_argument("--layers-figure", help="also draw LGMD1's P layer under each front end "
                    "on a hand-held and a robot frame (PNG)")
    args = ap.parse_args(argv)
    first, stop = (int(v) for v in args.seeds.split(":"))
    names = models.available() if args.models == "all" else args.models.split(",")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plan = {}
    for group in args.groups.split(","):
        fronts = ROBOT_FRONTS if group == "robot" else FRONTS
        for scenario, jitter, extra in GROUPS[group]:
            for seed in range(first, stop):
                plan[clip_key(scenario, jitter, extra, seed)] = (scenario, jitter, extra, seed,
                                                                 fronts)
    records = []
    for key, (scenario, jitter, extra, seed, fronts) in plan.items():
        path = out / f"{key}.json"
        if not path.exists():
            start = time.perf_counter()
            rec = run_clip(scenario, jitter, extra, seed, args.resolution, names, fronts)
            write_text_atomic(path, json.dumps(rec))
            print(f"{key}: {rec['frames']} frames, {time.perf_counter() - start:.0f} s",
                  file=sys.stderr, flush=True)
        records.append(json.loads(path.read_text()))
    command = shlex.join(["python", "docs/experiments/tools/compensation_table.py",
                          *(argv or sys.argv[1:])])
    text = (f"<!-- {command} -->\n\n" + main_table(records, names) + "\n"
            + robot_table(records, names) + "\n" + brightness_table(records, names) + "\n"
            + rotation_table(records))
    write_text_atomic(out / "tables.md", text)
    print(text, end="")
    if args.figure:
        figure(records, names, Path(args.figure))
    if args.layers_figure:
        layers_figure(Path(args.layers_figure), args.resolution)
    return 0


if __name__ == "__main__":
    sys.exit(main())
