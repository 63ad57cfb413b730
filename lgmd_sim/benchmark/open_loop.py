"""`lgmd-sim bench open-loop`: the paper's Tables 2 and 3 and its noise figures, simulated.

Clips are episodes of the scenarios (the carrier driving straight, as `lgmd-sim record`
does) or the episodes of a dataset (``--dataset``); every detector runs on the same
frames. The stationary clips (a scenario whose carrier does not shake, at jitter 0) are
also run corrupted by Gaussian and salt-and-pepper noise at each ``noise_levels`` value,
as the paper's dataset (d). Per clip and detector: ISI, MpSI, SI (never-crossed counted
as 1, with its flag), the first alarm, hit / miss / false alarm against the labelled
collision with a window of ``window`` seconds, the lead time. Per group (scenario, jitter,
noise, detector): the same over the seeds, and the ROC AUC of the per-frame potential as a
detector of "an obstacle is within ``horizon`` seconds of collision", pooled over the
group's frames: one threshold hides what a model can do.
"""

from __future__ import annotations

import base64
import statistics
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.controllers import options
from lgmd_sim.core.configfile import setting
from lgmd_sim.core.fileio import csv_text, write_files, write_text_atomic
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.core.params import checked, count, non_negative, positive, seed
from lgmd_sim.core.runs import NULL, NUMBER, RunFolder, RunResult
from lgmd_sim.signals import metrics

__all__ = ["Clip", "OpenLoopConfig", "clip_job", "run", "summarise",
           "summary_markdown"]

#: The paper's noise kinds for its dataset (d).
NOISE_KINDS = ("gaussian", "saltpepper")


@dataclass(frozen=True)
class Clip:
    """Where a clip's frames come from: a scenario episode, or a dataset's episode."""

    scenario: str
    jitter: float
    seed: int
    dataset: str | None = None  # the dataset folder, for a dataset episode
    index: int | None = None  # its episode index

    @property
    def key(self) -> str:
        if self.dataset is not None:
            return f"{self.scenario}-j{self.jitter:g}-e{self.index}"
        return f"{self.scenario}-j{self.jitter:g}-s{self.seed}"


def _frames(clip: Clip, resolution: Any
            ) -> tuple[list[np.ndarray], np.ndarray, int | None, float, list[dict] | None]:
    """The clip's RGB frames, each frame's time to collision, its collision frame, fps, and
    each frame's ground truth (for front ends fed by the pose or the IMU; None when the
    clip's labels do not carry the rotations)."""
    if clip.dataset is not None:
        from lgmd_sim import data

        ep = data.open(clip.dataset).episode(clip.index)
        columns = [c for c in ("pose_rotation", "imu_rotation") if c in ep.labels.column_names]
        table = ep.labels.select(["threat_ttc", *columns]).to_pylist()
        ttc = np.array([row["threat_ttc"] for row in table], float)
        infos = [{c: np.asarray(row[c]) for c in columns} for row in table] if columns else None
        return list(ep.frames()), ttc, ep.collision_frame, ep.fps, infos
    from lgmd_sim.controllers import Straight, rollout
    from lgmd_sim.envs.reuse import episode_env
    from lgmd_sim.envs.wrappers.frames import check_frame_space

    with episode_env(clip.scenario, jitter=clip.jitter, resolution=resolution) as env:
        check_frame_space(env.observation_space)
        steps = list(rollout(env, Straight(), seed=clip.seed))
        fps = float(env.unwrapped.params.fps)
    frames = [s.obs["frame"] for s in steps]
    ttc = np.array([s.info["threat_ttc"] for s in steps], float)
    hit = steps[-1].info["first_collision_frame"]
    return frames, ttc, (int(hit) if hit >= 0 else None), fps, [s.info for s in steps]


def clip_job(clip: Clip, detectors: Sequence[tuple[str, str]], noises: Sequence[str], *,
             resolution: Any, horizon: float, window: float, figure: bool) -> dict[str, Any]:
    """Run every detector on one clip and on each noisy version of it (a job)."""
    from lgmd_sim import models
    from lgmd_sim.detect import detect
    from lgmd_sim.signals import noise

    frames, ttc, collision, fps, infos = _frames(clip, resolution)
    record: dict[str, Any] = {
        "scenario": clip.scenario, "jitter": clip.jitter, "seed": clip.seed,
        "episode": clip.index, "frames": len(frames), "fps": fps,
        "collision_frame": collision, "near": (ttc < horizon).astype(int).tolist(),
        "rows": [],
    }
    for variant in ("", *noises):
        if variant:
            spec = noise.parse(variant)
            seen = [noise.apply(f, spec, clip.seed, i) for i, f in enumerate(frames)]
        else:
            seen = frames
        built = {f"{m}/{p}": models.make(m, preset=p) for m, p in detectors}
        d = detect(seen, fps, built, collision, name=clip.key, window_s=window, infos=infos)
        for label, tr in d.models.items():
            record["rows"].append({
                "noise": variant, "detector": label, "isi": d.isi, "mpsi": tr.mpsi,
                "si": tr.sensitivity.si, "crossed": tr.sensitivity.crossed,
                "first_alarm": tr.first_alarm,
                "outcome": tr.event.outcome if tr.event else
                ("false_alarm" if tr.first_alarm is not None else "correct_rejection"),
                "lead_s": tr.event.lead_s if tr.event else None,
                "potential": np.round(tr.potential, 4).tolist(),
            })
        if figure and not variant:
            record["figure_png"] = base64.b64encode(_clip_figure(clip, seen, d)).decode()
    return record


#: What the tables and figures read of a clip's record: one holding less is refused on
#: resuming.
RECORD_FIELDS = {
    "scenario": str, "jitter": NUMBER, "collision_frame": (int, NULL), "near": list,
    "rows": [{"noise": str, "detector": str, "isi": (NUMBER, NULL), "mpsi": (NUMBER, NULL),
              "si": (NUMBER, NULL), "crossed": bool, "outcome": str, "lead_s": (NUMBER, NULL),
              "potential": list}],
}


def _clip_figure(clip: Clip, frames: Sequence[np.ndarray], d: Any) -> bytes:
    """The paper's layout for one clip: a frame, its P layer, every model's potential and
    the distribution of SSIM between consecutive frames."""
    import io

    from lgmd_sim.core.frames import to_grey
    from lgmd_sim.core.plots import figure
    from lgmd_sim.detect.figure import draw_potentials

    t = min(len(frames) - 1, max(1, round(0.8 * (d.collision_frame or len(frames) - 1))))
    p = np.abs(to_grey(frames[t]).astype(np.int16) - to_grey(frames[t - 1]).astype(np.int16))
    fig = figure(figsize=(13, 6.5))
    grid = fig.add_gridspec(2, 3, width_ratios=[1, 1, 1.25])
    ax = fig.add_subplot(grid[0, 0])
    ax.imshow(frames[t])
    ax.set_title(f"(a) frame {t}", fontsize="medium")
    ax.axis("off")
    ax = fig.add_subplot(grid[0, 1])
    ax.imshow(p, cmap="gray", vmin=0, vmax=max(int(np.percentile(p, 99.5)), 1))
    ax.set_title(f"(b) P layer |L({t}) - L({t - 1})|", fontsize="medium")
    ax.axis("off")
    ax = fig.add_subplot(grid[0, 2])
    ax.hist(d.ssim[1:], bins=20, range=(min(0.0, float(np.min(d.ssim[1:]))), 1.0),
            color="0.5", edgecolor="black")
    ax.set_title(f"(d) SSIM of consecutive frames: ISI {d.isi:.3f}", fontsize="medium")
    ax.set_xlabel("SSIM")
    ax.set_ylabel("frames")
    ax = fig.add_subplot(grid[1, :])
    draw_potentials(ax, d)
    ax.set_title("(c) membrane potentials", fontsize="medium")
    fig.suptitle(f"{clip.scenario}, jitter {clip.jitter:g}, seed {clip.seed}")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return buf.getvalue()


# --- tables ---------------------------------------------------------------------------------


def _mean(values: Sequence[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else None


def summarise(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (scenario, jitter, noise, detector) over the clips."""
    groups: dict[tuple, list[tuple[dict, dict]]] = defaultdict(list)
    for rec in records:
        for row in rec["rows"]:
            groups[(rec["scenario"], rec["jitter"], row["noise"], row["detector"])].append(
                (rec, row))
    out = []
    for (sc, j, variant, det), pairs in groups.items():
        collision = [r for c, r in pairs if c["collision_frame"] is not None]
        none = [r for c, r in pairs if c["collision_frame"] is None]
        scores = np.concatenate([r["potential"] for _, r in pairs])
        near = np.concatenate([c["near"] for c, _ in pairs]).astype(bool)
        leads = [r["lead_s"] for r in collision if r["outcome"] == "hit"]
        out.append({
            "scenario": sc, "jitter": j, "noise": variant, "detector": det,
            "clips": len(pairs), "isi": _mean([r["isi"] for _, r in pairs]),
            "mpsi": _mean([r["mpsi"] for _, r in pairs]),
            "si": _mean([r["si"] for _, r in pairs]),
            "crossed": float(np.mean([r["crossed"] for _, r in pairs])),
            "hit_rate": (sum(r["outcome"] == "hit" for r in collision) / len(collision)
                         if collision else None),
            "false_alarm_rate": (sum(r["outcome"] == "false_alarm" for r in none) / len(none)
                                 if none else None),
            "median_lead_s": statistics.median(leads) if leads else None,
            "auc": metrics.roc_auc(scores, near),
        })
    return sorted(out, key=lambda r: (r["scenario"], r["jitter"], r["noise"], r["detector"]))


_COLUMNS = ["scenario", "jitter", "noise", "detector", "clips", "isi", "mpsi", "si", "crossed",
            "hit_rate", "false_alarm_rate", "median_lead_s", "auc"]


def summary_markdown(rows: Sequence[dict[str, Any]], noise: bool = False) -> str:
    """The clean clips' summary (or, with `noise`, every noise level) as Markdown."""

    def f(x: float | None, digits: int = 3) -> str:
        return "-" if x is None else f"{x:.{digits}f}"

    lines = ["| scenario | jitter | noise | detector | clips | ISI | MpSI | SI | crossed | "
             "hits | false alarms | lead (s) | ROC AUC |",
             "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if bool(r["noise"]) != noise:
            continue
        lines.append(
            f"| {r['scenario']} | {r['jitter']:g} | {r['noise'] or '-'} | {r['detector']} | "
            f"{r['clips']} | {f(r['isi'])} | {f(r['mpsi'])} | {f(r['si'])} | "
            f"{f(r['crossed'], 2)} | {f(r['hit_rate'], 2)} | {f(r['false_alarm_rate'], 2)} | "
            f"{f(r['median_lead_s'], 2)} | {f(r['auc'])} |")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class OpenLoopConfig:
    """What an open-loop benchmark runs, checked when it is made (a bad value raises a
    one-line ValueError naming it). Each field is declared with its meaning
    (`lgmd_sim.core.configfile.setting`): the command line's options and --config keys.
    """

    scenarios: tuple[str, ...] | None = setting(
        None, "catalogue scenario names, each run at every jitter level with seeds clips "
        "seeded from first_seed; ignored with dataset; unset: every scenario")
    jitter: tuple[float, ...] = setting((0.0, 1.0), "jitter levels")
    seeds: int = setting(8, "clips per scenario and jitter level")
    first_seed: int = setting(0, "the first episode seed")
    dataset: str | None = setting(None, "take the clips from a dataset (DIR, or DIR:N for its "
                                  "episode N) instead of simulating them")
    detectors: tuple[tuple[str, str], ...] | None = setting(
        None, "(model, preset) pairs, presets with any front ends; unset: every model at "
        "its default preset")
    noise_levels: tuple[float, ...] = setting(
        (0.001, 0.003, 0.005, 0.007, 0.009), "Gaussian variances and salt-and-pepper "
        "densities at which the stationary clips (a tripod scenario at jitter 0) also run "
        "(the paper's dataset d); [] for none")
    resolution: str | tuple[int, int] = setting(
        "paper", "frame size of simulated clips: paper (270x480), rl (120x160), small or HxW")
    horizon: float = setting(1.0, "a frame counts as dangerous when an obstacle is within "
                             "this time to collision (s), for the ROC AUC")
    window: float = setting(1.0, "a first alarm within this many seconds before the "
                            "collision is a hit")

    def __post_init__(self) -> None:
        from lgmd_sim.envs.catalogue import scenarios

        def set_(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        every = list(scenarios())
        set_("scenarios", tuple(every if self.scenarios is None else options.names(
            self.scenarios, every, "scenario(s)")))
        set_("jitter", tuple(float(j) for j in self.jitter))
        checked("jitter", self.jitter, options.jitter_list)
        checked("seeds", self.seeds, count)
        checked("first_seed", self.first_seed, seed)
        set_("detectors", options.detectors("all") if self.detectors is None
             else options.check_detectors(self.detectors))
        checked("noise_levels", self.noise_levels, options.noise_list)
        set_("noise_levels", tuple(float(v) for v in self.noise_levels))
        set_("resolution", options.resolution(self.resolution))
        checked("horizon", self.horizon, positive)
        checked("window", self.window, non_negative)
        if self.dataset is not None:
            self.clips()  # a folder that is not a dataset fails now, not in a worker

    def clips(self) -> list[Clip]:
        """The clips, in the order the tables list them."""
        if self.dataset is not None:
            from lgmd_sim import data

            episodes = data.episodes(self.dataset)
            if episodes is None:
                raise ValueError(f"{self.dataset} is not a dataset (nor DIR:N, an episode of "
                                 "one)")
            return [Clip(ep.scenario, ep.jitter, ep.seed, str(ep.root), ep.index)
                    for ep in episodes]
        seeds = range(self.first_seed, self.first_seed + self.seeds)
        return [Clip(sc, j, s) for sc in self.scenarios for j in self.jitter for s in seeds]

    def noises(self) -> list[str]:
        """The noise variants of the stationary clips ("gaussian:0.005", ...)."""
        return [f"{kind}:{level:g}" for kind in NOISE_KINDS for level in self.noise_levels]

    def as_json(self, clips: Sequence[Clip]) -> dict[str, Any]:
        """The configuration as the run folder records it (what identifies the run)."""
        return {"benchmark": "open-loop", "clips": [c.key for c in clips],
                "dataset": self.dataset, "detectors": [list(d) for d in self.detectors],
                "noise": self.noises(), "resolution": self.resolution,
                "horizon": self.horizon, "window": self.window}


def _noisy(clips: Sequence[Clip]) -> set[str]:
    """The keys of the paper's dataset (d): its stationary clips (a tripod, no jitter)."""
    from lgmd_sim.envs.catalogue import params_for

    tripods = {sc for sc in {c.scenario for c in clips}
               if params_for(sc, {}).carrier == "tripod"}
    return {c.key for c in clips if c.scenario in tripods and c.jitter == 0}


def run(config: OpenLoopConfig, out: str | Path, options: RunOptions = RunOptions()
        ) -> RunResult:
    """Run (or resume) the benchmark of `config` in folder `out`; write its tables and
    figures (see `lgmd_sim.benchmark.closed_loop.run` for the arguments)."""
    from lgmd_sim.benchmark import open_loop_figures
    from lgmd_sim.models.check import preflight

    preflight(config.detectors)
    clips = config.clips()
    noisy = _noisy(clips)
    noises = config.noises()
    folder = RunFolder(out, config.as_json(clips), options.command, resume=options.resume)
    done = folder.done()
    first = {}
    for c in clips:  # the figure of each (scenario, jitter): its first clip
        first.setdefault((c.scenario, c.jitter), c.key)
    jobs = [Job(c.key, clip_job, {
        "clip": c, "detectors": config.detectors,
        "noises": noises if c.key in noisy else (),
        "resolution": config.resolution, "horizon": config.horizon, "window": config.window,
        "figure": first[(c.scenario, c.jitter)] == c.key,
    }) for c in clips if c.key not in done]
    run_jobs(jobs, lambda job, record: folder.store(job.key, record), options,
             desc="open-loop", unit="clip")
    records = folder.records([c.key for c in clips], RECORD_FIELDS)
    rows = summarise(records)
    write_text_atomic(folder.path / "summary.csv", csv_text(rows, _COLUMNS))
    write_text_atomic(folder.path / "summary.md", summary_markdown(rows))
    if noises:
        write_text_atomic(folder.path / "noise.md", summary_markdown(rows, noise=True))
    clip_figures = {folder.path / f"clip_{r['scenario']}_j{r['jitter']:g}.png":
                    base64.b64decode(r["figure_png"]) for r in records if "figure_png" in r}
    write_files({path: (lambda tmp, png=png: tmp.write_bytes(png))
                 for path, png in clip_figures.items()})
    made = open_loop_figures.open_loop(folder.path, rows, records)
    folder.finish(clips=len(records))
    files = ["summary.csv", "summary.md", *(["noise.md"] if noises else []),
             *sorted(p.name for p in clip_figures), *made, "run.json"]
    return RunResult(folder.path, rows, files)
