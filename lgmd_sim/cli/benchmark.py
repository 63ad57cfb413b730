"""`lgmd-sim benchmark`: entries through every track of a protocol, one result each."""

from __future__ import annotations

import argparse
from pathlib import Path

from lgmd_sim.cli.args import add_parallel_options, advanced, run_options


def add(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "benchmark", help="run detectors, controllers or policies through the benchmark's "
        "protocol: one comparable result each",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="""\
Run each ENTRY through every track of the protocol (lgmd_sim/benchmark/v2.toml: its
seeds, 20000 and up, are no calibration's, training's or evaluation's) and write
OUT/<entry>/result.json: the protocol's version and digest, the entry and its resolved
parameters, the scores with 95% bootstrap intervals, the raw metrics, each episode's
fingerprint, the machine.

Tracks and scores of protocol v2 (each in [0, 1], higher is better):
  goal       RoughTerrainObstacles at jitter 0, 0.5, 1, 1.5, 2, 3, 20 episodes each:
             success weighted by path efficiency (SPL); a robot that never moves scores 0
  arena      ArenaRoam at the same levels: the share of encounters avoided times the
             distance travelled over the Oracle's (at most 1)
  detection  (detectors) the robot's own camera, no controller: 6 clips of driving at a
             box or a wall and past obstacles or over open ground at each level; the mean
             of approach clips alarmed 0.6-1.15 s before collision (the manoeuvre's
             window), clear clips silent, window frames alarmed, clear frames silent
  stimuli    (detectors) synthetic looming and non-looming clips (v1's detection), a table
             of its own
  overall    the mean of goal and arena; J50, the level at which it halves, beside it

An ENTRY is a detector driving the reference controller (ReactiveAvoid, its constants
as they ship; @eyes: with two LGMDs) or the controller named after '@' (@loom-steer):
MODEL[/PRESET][+FRONT...][@eyes|@CONTROLLER], a built-in name or a
package.module:Class spec; or a controller (oracle, straight, steer, a spec); or a
policy folder (or shipped). A detector runs 240 episodes and 384 clips (each shipped
row's wall time and machine: docs/leaderboard.md). Running the same command again
completes an interrupted benchmark. Then:
lgmd-sim leaderboard OUT/*/result.json --out leaderboard.md""")
    p.add_argument("entries", nargs="+", metavar="ENTRY",
                   help="detectors, controllers or policy folders (see above)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder, one subfolder per entry (default ./benchmark-out; "
                   "with --smoke ./benchmark-smoke)")
    p.add_argument("--smoke", action="store_true",
                   help="every track and the calibration on a handful of seeds (2 episodes "
                   "a track and level, 1 clip a scenario or stimulus and level, 2 "
                   "calibration settings): "
                   "a plug-in's errors and its output in a few minutes; the result is "
                   "marked as a smoke result, which no leaderboard ranks")
    p.add_argument("--calibrate", action="store_true",
                   help="first tune each detector by the protocol's calibration rule (the "
                   "robot task, budget 16, search seeds 0-5, held-out 100-105, as the shipped "
                   "robot presets), on its front end, so that a new model is compared "
                   "fairly: its row is MODEL/robot[-FRONT] (a built-in's, which ships that "
                   "preset: MODEL/robot[-FRONT]-recalibrated); a few minutes more")
    more = advanced(p, "another protocol than the shipped one")
    more.add_argument("--protocol", default="v2", metavar="NAME|FILE",
                      help="a shipped protocol (v2, the default; v1, the first) or a "
                      "protocol TOML file (docs/benchmark.md says how to write one)")
    add_parallel_options(p)


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.benchmark import entries, protocol
    from lgmd_sim.benchmark.run import RESULT, benchmark, calibrated, check_entries
    from lgmd_sim.core.fileio import held_lock

    proto = protocol.load(args.protocol)
    if args.smoke:
        proto = proto.smoke()
    out = args.out or ("benchmark-smoke" if args.smoke else "benchmark-out")
    parsed = [entries.parse(e) for e in args.entries]  # every entry checked before any runs
    check_entries(parsed, proto)
    # checked before the entries' folders are made
    options = run_options(args)
    if args.calibrate and any(e.kind != "detector" for e in parsed):
        raise ValueError("--calibrate tunes detectors: give detectors only")
    for entry in parsed:
        # two runs of one entry into one folder would both compute everything, and one's
        # record of its sessions would lose the other's
        busy = (f"{out}/{entry.key}: another lgmd-sim benchmark is running this entry "
                "into this folder now: wait for it, or choose another --out")
        with held_lock(Path(out) / f".{entry.key}.lock", busy):
            presets = None
            if args.calibrate:
                entry, presets = calibrated(entry, proto, out, options)
            result = benchmark(entry, proto, out, options, presets=presets)
        s = result["scores"]
        shown = ", ".join(f"{k} {v:.2f}" for k, v in s.items())
        smoke = " (a smoke result: not a row)" if args.smoke else ""
        print(f"{entry.label}: {shown}{smoke}; wrote {out}/{entry.key}/{RESULT}")
    return 0
