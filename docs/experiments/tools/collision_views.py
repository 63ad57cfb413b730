"""Did the robot see what it hit? Each collision's obstacle in the camera's frames before it.

Replays the collisions of a closed-loop evaluation (an ``lgmd-sim bench closed-loop`` run
folder, with ``--policies`` or without, of scenarios whose episodes end at a collision:
its cells and seeds, the episodes its episodes.csv records as collided). In each frame of
the last WINDOW seconds before a hit it renders the camera's segmentation (which geom
each pixel shows, so occlusion and the frame's edges count: what the controller's
detector was shown) and takes the bearing of the nearest point of the obstacle hit. It
reports how many pixels of that obstacle the camera saw LAGS seconds before the hit: an
obstacle out of the frame then is one that no detector on this camera could warn of in
time, while the Oracle and the privileged policy read the truth wherever the obstacle is.
For a controller that steers by its detector's excitation (LoomSteer: 0 at rest, 1 at the
alarm threshold) it also records that excitation and the alarm on each frame, so that an
obstacle in view the detector did not answer to is told from one it alarmed for too late.
A replay must end in the recorded collision frame (the same processor plays the same
episode); one that does not is counted apart and left out.

    python docs/experiments/tools/collision_views.py EVAL OUT [--workers N]

Writes OUT/collisions.csv (one row per collision: the cell, the seed, the obstacle hit,
its pixels and bearing at each lag), OUT/collision_views.md (per cell: its collisions
and how many hit an obstacle out of the frame at each lag, with the command) and
OUT/collision_views.png (the bearing and the visible pixels of the obstacle hit over the
last WINDOW seconds before each collision, and the excitation where there is one).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import shlex
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import controllers
from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
from lgmd_sim.benchmark.episode import Cell, driven
from lgmd_sim.benchmark.summary import cell_of
from lgmd_sim.cli.args import error_line
from lgmd_sim.core.extras import MissingExtra
from lgmd_sim.core.fileio import atomic_outputs, read_text
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.core.params import checked, count
from lgmd_sim.core.runs import NULL, NUMBER, RECORD, Fields, Maybe, read_record
from lgmd_sim.detect.outputs import check_out_folder
from lgmd_sim.envs.catalogue import params_for
from lgmd_sim.models.check import preflight
from lgmd_sim.world.gl import mujoco  # mujoco with the GL backend chosen

#: Seconds before the collision at which the obstacle hit is looked for in the frame.
LAGS = (0.25, 0.5, 1.0)
#: Seconds of each collision's approach kept and drawn.
WINDOW = 2.0
#: How far (m) mj_geomDistance looks: beyond the arena's diagonal.
FAR = 50.0
#: What the replay reads of a closed-loop run's run.json (`ClosedLoopConfig.from_json`): a
#: record holding something else is refused naming the file, not met as a traceback.
CONFIG_FIELDS: Fields = {"config": {
    "scenarios": [str], "jitter": [NUMBER], "controllers": [str], "detectors": [[str]],
    "seeds": [int], "resolution": (str, [int]), "cruise": NUMBER, "horizon": NUMBER,
    "extra": Maybe([{"scenario": str, "jitter": NUMBER, "controller": str,
                     "model": Maybe(str), "preset": Maybe(str), "params": dict,
                     "tag": (str, NULL)}]),
    "sides": Maybe([str]), "top_views": Maybe(int)}}
#: What a user whose folder is refused can do about it.
REMEDY = "give the run folder of an lgmd-sim bench closed-loop run (--policies or not)"
#: The columns of episodes.csv the replay reads.
COLUMNS = ("scenario", "jitter", "controller", "model", "preset", "seed", "frames",
           "collided")


def views(cell: Cell, seed: int, resolution: Any, cruise: float, frame: int
          ) -> dict[str, Any]:
    """Replay one collided episode of `cell` (a job) whose record puts the collision at
    `frame`: the threat hit and, for each frame of the last WINDOW seconds up to the hit,
    its visible pixels and the bearing (degrees, positive to the left) of its nearest
    point from the camera; ``replayed`` False where the replay went otherwise."""
    pixels, bearings, before, excitation, alarms = [], [], [], [], []
    with driven(cell, resolution=resolution, cruise=cruise) as (env, controller):
        world = env.unwrapped.world
        m, d, sc = world.model, world.data, world.scene
        owner = np.full(m.ngeom, -1)
        owner[sc.threat_geoms] = sc.threat_owner
        first = frame - round(WINDOW * world.params.fps)
        fromto = np.empty(6)
        # A renderer of its own: the kept environment's terrain changes at each reset.
        seg = mujoco.Renderer(m, world.height, world.width)
        seg.enable_segmentation_rendering()
        try:
            for step in controllers.rollout(env, controller, seed=seed):
                last = step.info
                if step.index < first:
                    continue
                seg.update_scene(d, camera=sc.camera)
                ids = seg.render()
                geom = ids[..., 0][ids[..., 1] == mujoco.mjtObj.mjOBJ_GEOM]
                shown = owner[geom[geom >= 0]]
                pixels.append(np.bincount(shown[shown >= 0], minlength=sc.n_threats))
                cam = d.cam_xpos[sc.camera]
                axes = d.cam_xmat[sc.camera].reshape(3, 3)
                forward, left = -axes[:, 2], -axes[:, 0]  # the camera looks along its -z
                nearest = np.full(sc.n_threats, np.inf)
                row = np.full(sc.n_threats, np.nan)
                for g, i in zip(sc.threat_geoms, sc.threat_owner, strict=True):
                    gap = mujoco.mj_geomDistance(m, d, sc.carrier_main_geom, g, FAR, fromto)
                    if gap < nearest[i]:
                        to = fromto[3:] - cam
                        nearest[i] = gap
                        row[i] = math.degrees(math.atan2(to @ left, to @ forward))
                bearings.append(row)
                before.append(step.index)
                if hasattr(controller, "excitation"):  # the collision frame: the one before
                    excitation.append(round(float(np.max(controller.excitation)), 4))
                    alarms.append(bool(controller.alarm))
        finally:
            seg.close()
        if int(last["first_collision_frame"]) != frame:
            return {"replayed": False}
        hit = int(last["threat_index"])  # a threat touched ranks first (JitterWorld)
        half_fov = math.degrees(math.atan(math.tan(math.radians(world.params.fovy) / 2)
                                          * world.width / world.height))
        return {"replayed": True, "hit": hit, "wall": hit >= world.params.n_obstacles,
                "half_fov": half_fov, "frame_pixels": world.height * world.width,
                "before": [round((frame - i) / world.params.fps, 4) for i in before],
                "pixels": [int(p[hit]) for p in pixels],
                "bearing": [round(float(b[hit]), 2) for b in bearings],
                "excitation": excitation or None, "alarm": alarms or None}


def at(record: dict[str, Any], lag: float) -> int:
    """Index of the frame `lag` seconds (or the nearest before) before the collision."""
    before = np.asarray(record["before"])
    later = np.flatnonzero(before >= lag - 1e-6)
    return int(later[-1]) if len(later) else 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("eval", type=Path, help="a closed-loop evaluation's run folder")
    parser.add_argument("out", type=Path, help="the folder to write the tables and figure into")
    parser.add_argument("--workers", type=int, default=None,
                        help="local worker processes (default: every core)")
    args = parser.parse_args()
    try:
        replay(args.eval, args.out, args.workers)
    except (ValueError, OSError, MissingExtra) as exc:  # a bad input: one line naming it
        sys.exit(f"collision_views.py: {error_line(exc, parser, args)}")


def replay(folder: Path, out: Path, workers: int | None) -> None:
    """Replay the collisions of the run in `folder` and write their tables and figure into
    `out`: every input is checked before the first replay, and the outputs move into place
    as a set, so that a refusal or a failure leaves `out` as it was."""
    if workers is not None:
        checked("workers", workers, count)
    check_out_folder(out)
    config = _config(folder)
    cells = {cell.key(seed): cell for cell in config.cells() for seed in config.seed_list}
    jobs = _jobs(folder, config, cells)
    # a plug-in (controller or detector) that cannot run is refused now, not in a replay
    replayed = list(dict.fromkeys(job.kwargs["cell"] for job in jobs))
    for cell in replayed:
        controllers.controller_class(cell.controller)
    preflight((cell.model, cell.preset) for cell in replayed if cell.model)
    results: dict[str, dict[str, Any]] = {}
    run_jobs(jobs, lambda job, r: results.__setitem__(job.key, r), RunOptions(workers=workers),
             desc="collisions replayed")
    rows = sorted(((job.kwargs["cell"], job.kwargs["seed"], results[job.key]) for job in jobs),
                  key=lambda r: (r[0].jitter, r[0].label, r[1]))
    command = shlex.join(["python", *sys.argv])
    table = _markdown(list(dict.fromkeys(cells.values())), config.seeds, rows, command)
    figure = out / "collision_views.png"
    drawn = [row for row in rows if row[2]["replayed"]]
    with atomic_outputs([out / "collisions.csv", out / "collision_views.md",
                         *([figure] if drawn else [])]) as temps:
        temps[0].write_text(_csv(rows))
        temps[1].write_text(table)
        if drawn:
            _figure(drawn, temps[2])
    if not drawn:  # none replayed to its collision: an earlier figure would pass for this one
        figure.unlink(missing_ok=True)
    print(table)


def _config(folder: Path) -> ClosedLoopConfig:
    """The closed-loop configuration of run folder `folder` (a policy folder that has
    moved since, the run's recorded path, is looked up by its name, as a shipped one)."""
    file = folder / RECORD
    config = read_record(file, CONFIG_FIELDS, REMEDY)["config"]
    for cell in config.get("extra", ()):
        path = cell["params"].get("path")
        if path is not None and not Path(path).exists():
            cell["params"]["path"] = cell["tag"]
    try:
        return ClosedLoopConfig.from_json(config)
    except ValueError as exc:  # a scenario or plug-in this installation lacks
        raise ValueError(f"{file}: {exc}") from None


def _jobs(folder: Path, config: ClosedLoopConfig, cells: dict[str, Cell]) -> list[Job]:
    """A replay of each collided episode of `cells` that episodes.csv in `folder` records."""
    file = folder / "episodes.csv"
    reader = csv.DictReader(io.StringIO(read_text(file), newline=""))
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or ())]
    if missing:
        raise ValueError(f"{file} has no column {missing[0]!r}: {REMEDY}")
    jobs = []
    for line, r in enumerate(reader, 2):
        if r["collided"] != "True":
            continue
        try:
            record = {**{k: v or None for k, v in r.items()}, "jitter": float(r["jitter"])}
            seed, frame = int(r["seed"]), int(r["frames"]) - 1
            ends = params_for(r["scenario"], {}).terminate_on_collision
        except ValueError as exc:
            raise ValueError(f"{file}, line {line}: {exc}") from None
        if not ends:
            raise ValueError(f"{folder} holds {r['scenario']}, whose episodes go on after a "
                             "collision: only scenarios that end at one")
        key = cell_of(record).key(seed)
        if key in cells:
            jobs.append(Job(key, views, {"cell": cells[key], "seed": seed,
                                         "resolution": config.resolution,
                                         "cruise": config.cruise, "frame": frame}))
    if not jobs:
        raise ValueError(f"{folder} records no collision to replay")
    return jobs


Row = tuple[Cell, int, dict[str, Any]]


def _csv(rows: list[Row]) -> str:
    out = io.StringIO()
    w = csv.writer(out)
    w.writerow(["jitter", "cell", "seed", "threat", "arena_wall",
                *[f"{key}_{lag:g}s" for key in ("pixels", "bearing", "excitation")
                  for lag in (0, *LAGS)], f"alarms_last_{WINDOW:g}s"])
    for cell, seed, r in rows:
        if r["replayed"]:
            idx = [at(r, lag) for lag in (0, *LAGS)]
            excitation = r["excitation"] or [""] * len(r["pixels"])
            w.writerow([f"{cell.jitter:g}", cell.label, seed, r["hit"], r["wall"],
                        *[r["pixels"][i] for i in idx], *[r["bearing"][i] for i in idx],
                        *[excitation[i] for i in idx],
                        "" if r["alarm"] is None else sum(r["alarm"])])
    return out.getvalue()


def _markdown(cells: list[Cell], episodes: int, rows: list[Row], command: str) -> str:
    by_cell: dict[tuple[float, str], list[dict[str, Any]]] = defaultdict(list)
    for cell, _seed, r in rows:
        by_cell[(cell.jitter, cell.label)].append(r)
    lines = [f"```bash\n{command}\n```", "",
             "Per cell: its collisions, those replayed to the same collision frame, and of "
             "these how many hit an arena wall and how many an obstacle out of the camera's "
             "frame (no pixel of it in the segmentation) the given time before the hit, and "
             f"in every frame of the last {WINDOW:g} s:", "",
             *_head("episodes", "collisions", "replayed", "with an arena wall",
                    *[f"out of the frame {lag:g} s before" for lag in LAGS],
                    f"out of the frame all the last {WINDOW:g} s")]
    excited: list[tuple[Cell, list[dict[str, Any]]]] = []  # those with an excitation
    for cell in sorted(cells, key=lambda c: (c.jitter, c.label)):
        found = by_cell[(cell.jitter, cell.label)]
        hits = [r for r in found if r["replayed"]]
        outs = [sum(r["pixels"][at(r, lag)] == 0 for r in hits) for lag in LAGS]
        outs.append(sum(not any(r["pixels"]) for r in hits))
        lines.append(f"| {cell.jitter:g} | {cell.label} | {episodes} | {len(found)} | "
                     f"{len(hits)} | {sum(r['wall'] for r in hits)} | "
                     + " | ".join(f"{n} ({_pct(n, len(hits))})" for n in outs) + " |")
        excited.append((cell, [r for r in hits if r["excitation"]]))
    if any(hits for _cell, hits in excited):
        lines += ["", "What the controller's detector said before those collisions: its "
                  "excitation (the larger eye's; 0 at rest, 1 at the alarm threshold) the "
                  "given time before the hit, the median and the largest over the "
                  f"collisions, and how many saw an alarm in the last {WINDOW:g} s:", "",
                  *_head("replayed", *[f"excitation {lag:g} s before" for lag in LAGS],
                         f"an alarm in the last {WINDOW:g} s")]
        for cell, hits in excited:
            cols = [np.array([r["excitation"][at(r, lag)] for r in hits]) for lag in LAGS]
            alarmed = sum(any(r["alarm"]) for r in hits)
            lines.append(f"| {cell.jitter:g} | {cell.label} | {len(hits)} | "
                         + " | ".join(f"{np.median(x):.2f} ({x.max():.2f})" if len(x) else "-"
                                      for x in cols)
                         + f" | {alarmed} ({_pct(alarmed, len(hits))}) |")
    return "\n".join(lines) + "\n"


def _head(*columns: str) -> list[str]:
    """The heading and alignment rows of a per-cell table with these counts' columns."""
    return ["| jitter | controller | " + " | ".join(columns) + " |",
            "|---:|---|" + "---:|" * len(columns)]


def _pct(n: int, total: int) -> str:
    return f"{100 * n / total:.0f}%" if total else "-"


def _figure(rows: list[Row], path: Path) -> None:
    """Draw the collisions `rows` (each replayed to its collision) into `path` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = sorted({cell.label for cell, _seed, _r in rows})
    jitters = sorted({cell.jitter for cell, _seed, _r in rows})
    has_excitation = any(r["excitation"] for _cell, _seed, r in rows)
    panels = 2 + has_excitation
    fig, axes = plt.subplots(len(labels), panels, figsize=(5.5 * panels, 2.6 * len(labels)),
                             squeeze=False, sharex=True)
    colours = dict(zip(jitters, ("tab:blue", "tab:orange", "tab:green", "tab:red"),
                       strict=False))
    for row, label in enumerate(labels):
        ax_b, ax_p = axes[row][:2]
        mine = [(cell, r) for cell, _seed, r in rows if cell.label == label]
        for cell, r in mine:
            t = -np.asarray(r["before"])
            share = 100 * np.asarray(r["pixels"]) / r["frame_pixels"]
            ax_b.plot(t, r["bearing"], color=colours[cell.jitter], lw=0.8, alpha=0.7)
            ax_p.plot(t, share, color=colours[cell.jitter], lw=0.8, alpha=0.7)
            if r["excitation"]:
                axes[row][2].plot(t, r["excitation"], color=colours[cell.jitter], lw=0.8,
                                  alpha=0.7)
        if has_excitation:
            axes[row][2].axhline(1.0, color="black", ls="--", lw=0.8)
            axes[row][2].set_ylim(-0.05, 2.05)
            axes[row][2].set_ylabel("excitation")
        fov = mine[0][1]["half_fov"]
        ax_b.axhspan(-fov, fov, color="0.88", zorder=0)
        ax_b.set_ylim(-180, 180)
        ax_b.set_yticks([-180, -90, 0, 90, 180])
        ax_b.set_ylabel("bearing (deg, left +)")
        ax_p.set_ylim(-2, 100)
        ax_p.set_ylabel("share of the frame (%)")
        ax_b.set_title(f"{label}: collisions {len(mine)}", fontsize=9, loc="left")
    for ax in axes[-1]:
        ax.set_xlabel("time to the collision (s)")
    handles = [plt.Line2D([], [], color=colours[j], label=f"jitter {j:g}") for j in jitters]
    handles.append(plt.Rectangle((0, 0), 1, 1, color="0.88",
                                 label="the camera's horizontal field of view"))
    if has_excitation:
        handles.append(plt.Line2D([], [], color="black", ls="--",
                                  label="the detector's alarm threshold"))
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8)
    fig.suptitle("The obstacle each collision hits: the bearing of its nearest point from the "
                 "camera, its pixels in the camera's frame"
                 + (", and the controller's excitation (the larger eye's)"
                    if has_excitation else ""),
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
