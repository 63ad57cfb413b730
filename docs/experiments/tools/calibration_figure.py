"""Draw a finished calibration's calibration.png again, with today's figure code and no
calibration rerun: from the run's run.json and calibrated.json (what docs/results keeps of
a run: no clips, no records), into the run's folder or with --out elsewhere
(docs/video/calibration.png is the video run's figure); or, with --task, from the shipped
presets file (lgmd_sim/models/calibrated.json, or --presets-file): the presets that
task's calibration command made, each of which records the command, in the order of its
--detectors. The PNG records this command (`lgmd_sim.core.pngtext`).

    .venv/bin/python docs/experiments/tools/calibration_figure.py \
        docs/results/calibration-video docs/results/calibration-robot-frames
    .venv/bin/python docs/experiments/tools/calibration_figure.py \
        docs/results/calibration-video --out docs/video/calibration.png
    .venv/bin/python docs/experiments/tools/calibration_figure.py \
        --task walker --out docs/results/calibration/calibration.png
    .venv/bin/python docs/experiments/tools/calibration_figure.py \
        --task robot --out docs/results/calibration-robot/calibration.png

The last two are docs/results/calibration's and docs/results/calibration-robot's figures:
those runs' folders were not kept, the presets they made were shipped. The first draws
each run's own calibration.png into its folder: no page shows those two, and the
repository does not keep them (docs/video/calibration.png, the second, is the video run's
figure a page shows).
"""

from __future__ import annotations

import argparse
import shlex
from collections.abc import Sequence
from pathlib import Path

from lgmd_sim.calibration.redraw import redraw
from lgmd_sim.calibration.tasks import TASKS
from lgmd_sim.models.presets import CALIBRATED


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="*", help="finished calibration run folders")
    ap.add_argument("--task", choices=list(TASKS),
                    help="instead of runs: the calibration of this task whose presets the "
                    "presets file holds")
    ap.add_argument("--presets-file", type=Path,
                    help=f"with --task: the presets file (default: the shipped {CALIBRATED.name})")
    ap.add_argument("--out", type=Path, help="where to write the figure (one run, or --task, "
                    "which needs it; default: calibration.png in each run's folder)")
    args = ap.parse_args(argv)
    if (args.task is None) == (not args.runs):
        ap.error("give run folders or --task, one of them")
    if args.presets_file is not None and args.task is None:
        ap.error("--presets-file goes with --task")
    if args.task is not None and args.out is None:
        ap.error("--task needs --out: a presets file keeps no figure")
    if args.out is not None and len(args.runs) > 1:
        ap.error("--out takes one run")
    out = [] if args.out is None else ["--out", str(args.out)]
    tool = ["python", "docs/experiments/tools/calibration_figure.py"]
    try:
        if args.task is not None:
            given = ([] if args.presets_file is None
                     else ["--presets-file", str(args.presets_file)])
            command = shlex.join([*tool, "--task", args.task, *given, *out])
            source = CALIBRATED if args.presets_file is None else args.presets_file
            print(f"wrote {redraw(source, args.out, command=command, task=args.task)}")
        for run in args.runs:
            command = shlex.join([*tool, str(run), *out])
            print(f"wrote {redraw(run, args.out, command=command)}")
    except ValueError as exc:  # a source that is not one calibration: its message, no trace
        ap.error(str(exc))


if __name__ == "__main__":
    main()
