"""`lgmd-sim dataset generate`: labelled jitter datasets, resumable and reproducible.

Every episode is one job (`lgmd_sim.data.episode.make_episode`, run by
`lgmd_sim.core.parallel.run_jobs` in this process, on a local pool or as Ray tasks): it
drives a scenario with a controller, encodes the camera frames and builds the per-frame
labels, and hands both back as bytes. Only this process writes into the dataset folder,
so the folder's state never depends on who ran a job (a Ray cluster needs no shared file
system), and:

- each episode is written atomically, its video first and its data file (the labels,
  carrying the episode's metadata) last: an episode is complete when its data file
  exists, names its video's SHA-256, and the video matches;
- ``meta/config.json`` is written before any episode (the folder is a
  `lgmd_sim.core.runs.RunFolder` whose identity is that file); re-running the same command
  resumes (complete episodes kept, partial ones removed and redone); another
  configuration into the same folder is refused, naming the difference;
- the manifest (``meta/info.json`` last, with the episode table, the task table, the
  card and the contact sheet) is written when every episode is complete.

Episodes depend only on (scenario, parameters, seed, controller, models, noise), so the
same command gives byte-identical files whatever the number of workers; the facts of
each run (the command, wall time, workers) go to ``meta/run.json`` alone.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import os
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lgmd_sim.controllers import options
from lgmd_sim.core.configfile import setting
from lgmd_sim.core.fileio import (
    canonical_json,
    remove_stale_partials,
    write_files,
    write_text_atomic,
)
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, default_workers, run_jobs
from lgmd_sim.core.params import FieldError, checked, count, one_of, seed
from lgmd_sim.core.pool import Pool
from lgmd_sim.core.runs import RunFolder
from lgmd_sim.data import layout
from lgmd_sim.data.episode import EpisodeResult, EpisodeSpec, make_episode
from lgmd_sim.data.manifest import write_manifest

__all__ = ["GenerateConfig", "Summary", "generate"]

#: Environment parameters a dataset sets as fields of its own, never as overrides.
_OWN_FIELDS = ("jitter", "resolution")


@dataclass(frozen=True)
class GenerateConfig:
    """What a dataset holds: every option of ``dataset generate`` that shapes its files,
    checked when it is made (a bad value raises a one-line ValueError naming it). Each field
    is declared with its meaning (`lgmd_sim.core.configfile.setting`): the command's options.
    """

    scenarios: tuple[str, ...] = setting(("all",), "catalogue scenario names (`lgmd-sim "
                                         "envs`), or all")
    jitter: tuple[float, ...] = setting((0.0, 1.0, 2.0),
                                        "jitter levels; every scenario runs at each")
    episodes: int = setting(10, "episodes per scenario and jitter level, seeded seed, seed + 1, "
                            "... (the same seeds at every level: paired worlds)")
    resolution: str | tuple[int, int] = setting(
        "paper", "frame size: paper (270x480), rl (120x160), small (64x64) or HxW")
    controller: str = setting("straight", "what drives the carrier: a name of "
                              "`lgmd_sim.controllers.available()` or a package.module:Class")
    models: tuple[str, ...] = setting(
        (), "LGMD models whose potential and alarm join the labels: names or specs")
    noise: tuple[str, ...] = setting(
        (), "noise variants, each kind:level, noises of one variant joined by + (e.g. "
        "gaussian:0.005, saltpepper:0.005): derived from the clean frames on loading, not "
        "stored")
    video: str = setting(layout.DEFAULT_VIDEO, "frame storage: huffyuv (lossless, fast), "
                         "ffv1 (lossless, about half the size, slower to write), mpeg4 "
                         "(lossy, small)")
    seed: int = setting(0, "the first episode seed")
    overrides: Mapping[str, Any] = setting(
        {}, "environment parameters for every scenario, e.g. time_limit=2 or "
        "miss_distance=0.5 (`lgmd-sim envs NAME` lists them)")

    def __post_init__(self) -> None:
        from lgmd_sim.envs.catalogue import scenarios

        if tuple(self.scenarios) == ("all",):
            object.__setattr__(self, "scenarios", tuple(scenarios()))
        object.__setattr__(self, "resolution", options.resolution(self.resolution))
        _validate(self)

    def as_json(self) -> dict[str, Any]:
        """The configuration as stored in meta/config.json: the options, the package
        version and what they resolve to (every parameter of each scenario, the
        controller and the models), so that a changed scenario file or model default is a
        different configuration too, not a silent mix of old and new episodes."""
        from lgmd_sim import __version__, controllers, models
        from lgmd_sim.envs.catalogue import params_for

        out = dataclasses.asdict(self)
        out["resolution"] = self.resolution if isinstance(self.resolution, str) else list(
            self.resolution)
        out["overrides"] = dict(self.overrides)
        out["version"] = __version__
        out["resolved"] = {
            "scenarios": {name: {k: v for k, v in dataclasses.asdict(
                params_for(name, self.env_overrides(self.jitter[0]))).items() if k != "jitter"}
                for name in self.scenarios},
            "controller": dataclasses.asdict(controllers.make(self.controller).params),
            "models": {m: dataclasses.asdict(models.make(m).params) for m in self.models},
        }
        return json.loads(json.dumps(out))  # tuples as lists, as read back

    def command(self) -> str:
        """The command that makes this dataset (``DIR``: its folder)."""
        res = self.resolution if isinstance(self.resolution, str) else "x".join(
            map(str, self.resolution))
        parts = ["lgmd-sim dataset generate", f"--scenarios {','.join(self.scenarios)}",
                 f"--jitter {','.join(f'{j:g}' for j in self.jitter)}",
                 f"--episodes {self.episodes}", f"--resolution {res}",
                 f"--controller {self.controller}"]
        if self.models:
            parts.append(f"--models {','.join(self.models)}")
        if self.noise:
            parts.append(f"--noise {','.join(self.noise)}")
        if self.video != layout.DEFAULT_VIDEO:
            parts.append(f"--video {self.video}")
        if self.seed:
            parts.append(f"--seed {self.seed}")
        parts += [f"--set {k}={json.dumps(v)}" for k, v in sorted(self.overrides.items())]
        return " ".join([*parts, "--out DIR"])

    def env_overrides(self, jitter: float) -> dict[str, Any]:
        return {**self.overrides, "jitter": jitter, "resolution": self.resolution}

    def specs(self) -> list[EpisodeSpec]:
        """Every episode, in episode-index order: scenario, then jitter, then seed."""
        specs = []
        for task, name in enumerate(self.scenarios):
            for jitter in self.jitter:
                for i in range(self.episodes):
                    specs.append(EpisodeSpec(len(specs), name, task, jitter, self.seed + i,
                                             self.env_overrides(jitter), self.controller,
                                             self.models, self.noise, self.video))
        return specs


@dataclass(frozen=True)
class Summary:
    """What a `generate` call did."""

    path: Path
    episodes: int
    frames: int
    made: int
    kept: int
    seconds: float


def _validate(config: GenerateConfig) -> None:
    """Check every option before any episode runs; a bad one raises a one-line ValueError
    naming it."""
    from lgmd_sim.envs.catalogue import params_for, scenarios
    from lgmd_sim.signals import noise

    if not config.scenarios:
        raise ValueError("no scenarios given")
    options.names(config.scenarios, list(scenarios()), "scenario(s)")
    if len(set(config.scenarios)) != len(config.scenarios):
        raise FieldError("scenarios", f"holds a scenario twice: {','.join(config.scenarios)}")
    checked("jitter", config.jitter, options.jitter_list)
    checked("episodes", config.episodes, count)
    checked("seed", config.seed, seed)
    options.controller_names([config.controller], "controller")
    if config.models:
        options.model_names(list(config.models))
    for variant in config.noise:
        if not noise.parse(variant.replace("+", ",")):
            raise FieldError("noise", f"holds an empty noise variant: {','.join(config.noise)}")
    if len(set(config.noise)) != len(config.noise):
        raise FieldError("noise", f"holds a variant twice: {','.join(config.noise)}")
    checked("video", config.video, one_of(*layout.VIDEO_FORMATS))
    for key in config.overrides:
        if key in _OWN_FIELDS:
            raise FieldError("overrides", f"sets {key}, a field of the dataset's own: give "
                             f"it as {key}, not as an environment parameter")
    rates = set()
    for name in config.scenarios:
        for j in config.jitter:
            params = params_for(name, config.env_overrides(j))
            if params.frame == "none":  # a dataset is its videos
                raise ValueError(f"{name}: frame='none' renders no frames to record: set "
                                 "frame=rgb or grey")
            rates.add(params.fps)
    if len(rates) > 1:
        raise ValueError(f"the scenarios run at different frame rates ({sorted(rates)}); a "
                         "dataset has one: set it with --set fps=...")


# --- the folder ---------------------------------------------------------------------------


def _complete(out: Path, spec: EpisodeSpec) -> dict[str, Any] | None:
    """The metadata of episode `spec` if it is complete on disk, else None."""
    import pyarrow.parquet as pq

    data, video = out / layout.data_path(spec.index), out / layout.video_path(spec.index,
                                                                             spec.video)
    if not (data.is_file() and video.is_file()):
        return None
    try:
        kv = pq.read_metadata(data).metadata or {}
        meta = json.loads(kv[layout.EPISODE_KEY])
    except (OSError, ValueError, KeyError):
        return None
    same = (meta.get("episode_index"), meta.get("scenario"), meta.get("jitter"),
            meta.get("seed")) == (spec.index, spec.scenario, spec.jitter, spec.seed)
    if not same or layout.sha256(video) != meta.get("video_sha256"):
        return None
    return meta


def _store(out: Path, spec: EpisodeSpec, result: EpisodeResult) -> None:
    """Write an episode: video first, its data file (the mark of completion) last."""
    write_files({
        out / layout.video_path(spec.index, spec.video): lambda tmp: tmp.write_bytes(
            result.video),
        out / layout.data_path(spec.index): lambda tmp: tmp.write_bytes(result.data),
    })


def _finish_episodes(out: Path, specs: list[EpisodeSpec]) -> None:
    """Set each data file's ``index`` column (a frame's index in the whole dataset, known
    once every episode before it is made, in any order) and write meta/stats.json from
    every episode's labels. Files already right are left as they are, so a rerun, or a
    run killed half-way through this, changes nothing more."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from lgmd_sim.data.stats import feature_stats

    tables, start = [], 0
    for spec in specs:
        path = out / layout.data_path(spec.index)
        read = pq.read_table(path)
        table = layout.with_index(read, start)  # a dataset made before it has no index
        if not table.equals(read):
            write_files({path: lambda tmp, t=table: pq.write_table(t, tmp, compression="zstd")})
        tables.append(table)
        start += table.num_rows
    stats = feature_stats(pa.concat_tables(tables))
    write_text_atomic(out / layout.STATS, canonical_json(stats))


def _full_folder(out: Path, exc: OSError) -> Path:
    """The folder whose device is full: the temporary folder, where an episode's video is
    encoded before it is stored, if `exc` names a file in it, else the dataset's."""
    if exc.filename is not None:
        failed = Path(os.fsdecode(exc.filename)).resolve()
        temp = Path(tempfile.gettempdir()).resolve()
        if failed.is_relative_to(temp) and not failed.is_relative_to(out.resolve()):
            return temp
    return out


def generate(config: GenerateConfig, out: str | Path, options: RunOptions = RunOptions(), *,
             pool: Pool | None = None) -> Summary:
    """Generate (or resume) the dataset of `config` in folder `out`.

    Args:
        config: what the dataset holds.
        out: the dataset folder: new, empty, or holding this configuration's dataset (it
            always resumes: its complete episodes are kept).
        options: how it runs (workers, Ray, progress, the command line for
            ``meta/run.json``).
        pool: run the episodes on this started `lgmd_sim.core.pool.Pool` instead (not with
            ``options.workers`` or ``options.ray_address``): its workers keep their
            environments.

    Raises:
        ValueError: a bad option or a folder holding something else (one line).
        OSError: a full disk or another write error, naming the folder; the complete
            episodes are kept (the same call resumes).
        WorkerDied: a worker died; the episodes it ran are redone by the same call.
    """
    from lgmd_sim.core.extras import require

    require("pyarrow", "data")
    if options.ray_address is not None:
        require("ray", "ray")
    from lgmd_sim import models
    from lgmd_sim.models.check import preflight

    out = Path(out)
    preflight(models.parse_spec(m) for m in config.models)
    start = time.monotonic()
    specs = config.specs()
    metas: dict[int, dict[str, Any]] = {}
    try:
        folder = RunFolder(out, config.as_json(), options.command, resume=True,
                           what="lgmd-sim dataset",
                           record=layout.RUNS, identity=layout.CONFIG)
        todo = []
        for spec in specs:
            for path in (layout.data_path(spec.index), layout.video_path(spec.index, spec.video)):
                remove_stale_partials(out / path)
            meta = _complete(out, spec)
            if meta is None:
                for path in (layout.data_path(spec.index),
                             layout.video_path(spec.index, spec.video)):
                    (out / path).unlink(missing_ok=True)  # a partial episode: redo it
                todo.append(spec)
            else:
                metas[spec.index] = meta
        kept = len(metas)

        def store(job: Job, result: EpisodeResult) -> None:
            _store(out, job.kwargs["spec"], result)
            metas[job.kwargs["spec"].index] = result.meta

        run_jobs([Job(s.key, make_episode, {"spec": s}) for s in todo], store, options,
                 pool=pool, desc=f"dataset {out.name}", count=lambda r: r.meta["length"])
        _finish_episodes(out, specs)
        write_manifest(out, config, [metas[s.index] for s in specs])
        seconds = time.monotonic() - start
        frames = sum(m["length"] for m in metas.values())
        summary = Summary(out, len(specs), frames, len(specs) - kept, kept, seconds)
        folder.session.update(episodes_made=summary.made, episodes_kept=kept, frames=frames,
                              workers=pool.size if pool else options.workers
                              or default_workers(), ray=options.ray_address)
        folder.finish()
        return summary
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            full = _full_folder(out, exc)
            raise OSError(f"no space left on the device of {full}: "
                          f"{len(metas)} complete episodes are kept in {out}; free space and "
                          "run the same command again to resume") from None
        raise
