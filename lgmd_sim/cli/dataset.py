"""`lgmd-sim dataset`: its arguments, and the `GenerateConfig` made from them."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from lgmd_sim.cli.args import (
    add_parallel_options,
    advanced,
    configured,
    names,
    non_negative_int,
    option,
    positive_int,
    resolution,
    run_options,
)
from lgmd_sim.controllers import options
from lgmd_sim.core.configfile import doc


def add(sub: argparse._SubParsersAction) -> None:
    from lgmd_sim.data.generate import GenerateConfig
    from lgmd_sim.data.layout import VIDEO_FORMATS

    p = sub.add_parser(
        "dataset", help="generate, verify and export labelled jitter datasets",
        description="Labelled jitter datasets: camera frames stored losslessly with the "
        "world's exact ground truth on every frame, in a LeRobot-like layout "
        "(see docs/guides/datasets.md). Needs the 'data' extra (pyarrow).",
    )
    what = p.add_subparsers(dest="what", required=True, metavar="WHAT")
    g = what.add_parser(
        "generate", help="generate (or resume) a dataset",
        description="Run EPISODES episodes of every scenario at every jitter level and store "
        "them in --out. Re-running the same command resumes an interrupted run; the same "
        "command gives byte-identical files whatever the number of workers, and on Ray.",
    )
    option(g, GenerateConfig, "scenarios", type=names, shown="all")
    option(g, GenerateConfig, "jitter")
    option(g, GenerateConfig, "episodes", type=positive_int)
    g.add_argument("--out", required=True, metavar="DIR", help="the dataset folder")
    option(g, GenerateConfig, "resolution", type=resolution)
    more = advanced(g, "what drives the carrier, LGMD labels, noise variants, the frames' "
                    "storage, seeds and environment parameters")
    option(more, GenerateConfig, "controller")
    option(more, GenerateConfig, "models", shown="none; all: every model")
    option(more, GenerateConfig, "noise", shown="none")
    option(more, GenerateConfig, "video", choices=tuple(VIDEO_FORMATS))
    option(more, GenerateConfig, "seed", type=non_negative_int)
    more.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                      help=f"{doc(GenerateConfig, 'overrides')}; repeatable")
    add_parallel_options(g)
    v = what.add_parser(
        "verify", help="check a dataset: counts, checksums, label consistency",
        description="Check that the dataset in DIR is complete and consistent; print each "
        "problem on a line and exit with status 1 if there is any.",
    )
    v.add_argument("path", metavar="DIR", help="the dataset folder")
    e = what.add_parser(
        "export", help="write a dataset in another format (LeRobot's)",
        description="Write the dataset SRC as a LeRobot v3.0 dataset in the new folder DEST, "
        "which LeRobot's LeRobotDataset opens: the frames re-encoded as MP4 (lossy), the "
        "labels with their index column, LeRobot's task table and feature statistics. "
        "DEST appears only when complete. Needs the 'lerobot' extra (PyAV, pyarrow).",
    )
    e.add_argument("source", metavar="SRC", help="the dataset folder")
    e.add_argument("dest", metavar="DEST", help="the new folder to write")
    e.add_argument("--format", choices=("lerobot",), default="lerobot",
                   help="the format (default lerobot: LeRobot's dataset v3.0)")
    e.add_argument("--codec", choices=("h264", "av1"), default="h264",
                   help="the videos' codec: h264 (default; CRF 18, decoded everywhere) or av1 "
                   "(LeRobot's own default; CRF 30, smaller, slower to write)")


def config_from_args(args: argparse.Namespace) -> Any:
    """The `GenerateConfig` of ``dataset generate``'s arguments (repeats kept: the
    configuration refuses a scenario or a level given twice)."""
    from lgmd_sim.data.generate import GenerateConfig
    from lgmd_sim.signals import noise

    models = None if args.models is None else (
        () if args.models in ("", "none") else tuple(options.model_names(args.models)))
    variants = None if args.noise is None else tuple(
        "+".join(map(str, noise.parse(v.replace("+", ",")))) for v in options.comma_list(
            args.noise))
    overrides: dict[str, Any] = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {item!r}: write NAME=VALUE, e.g. time_limit=2")
        try:
            overrides[key.strip()] = json.loads(value)
        except ValueError:
            overrides[key.strip()] = value
    jitter = None if args.jitter is None else options.jitter_levels(args.jitter,
                                                                    drop_repeats=False)
    return configured(GenerateConfig, args, {
        "scenarios": args.scenarios, "jitter": jitter, "episodes": args.episodes,
        "resolution": args.resolution, "controller": args.controller, "models": models,
        "noise": variants, "video": args.video, "seed": args.seed,
        "overrides": overrides or None})


def run(args: argparse.Namespace) -> int:
    if args.what == "verify":
        from lgmd_sim.data.verify import verify

        problems, counts = verify(args.path)
        for p in problems:
            print(f"lgmd-sim dataset verify: {p}", file=sys.stderr)
        if problems:
            print(f"{args.path}: {len(problems)} problem(s)")
            return 1
        print(f"{args.path}: OK: {counts['episodes']} episodes, {counts['frames']} frames; "
              "counts, checksums and labels consistent")
        return 0
    if args.what == "export":
        from lgmd_sim.data.export import ExportConfig, export

        s = export(ExportConfig(args.source, args.dest, args.format, args.codec))
        print(f"{s.path}: {s.episodes} episodes, {s.frames} frames as a LeRobot v3.0 dataset "
              f"({s.codec} MP4) in {s.seconds:.1f} s; open it with "
              f"LeRobotDataset('local/{s.path.name}', root='{s.path}')")
        return 0
    from lgmd_sim.core.jobs import WorkerDied
    from lgmd_sim.data.generate import generate

    try:
        s = generate(config_from_args(args), args.out, run_options(args))
    except WorkerDied as exc:
        print(f"lgmd-sim dataset: error: {exc}; the complete episodes are kept in {args.out}: "
              "run the same command again to resume", file=sys.stderr)
        return 1
    print(f"{s.path}: {s.episodes} episodes, {s.frames} frames ({s.made} made, {s.kept} "
          f"kept) in {s.seconds:.1f} s; check it with: lgmd-sim dataset verify {s.path}")
    return 0
