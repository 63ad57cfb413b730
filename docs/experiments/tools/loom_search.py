"""Where `LoomSteer`'s steering constants come from (lgmd_sim.controllers.loom): the same
budget for every detector, on the search seeds of RoughTerrainObstacles at jitter 1 at
the benchmark's frame size and cruise, in two rounds of eight settings: the design and
seven variations (which double as the ablations: no steering between the eyes, no
memory, shorter and longer turns), then eight variations of the first round's best. The
setting with the most successes less collisions (then the most successes; the first among
equals) over both rounds is that detector's choice; the benchmark's seeds (20000 and up)
are the held-out check. Each episode's record goes to
docs/experiments/loom-search/<detector>.json as it finishes, so that a stopped search
resumes. A ninth row, no candidate, runs the design with the video presets' alarm rule.
With --jitters, the chosen setting is then run at jitter 0, 1 and 2 beside itself without
each part it uses (the memory; the steering between the eyes), on the same seeds.

    .venv/bin/python docs/experiments/tools/loom_search.py lgmd1/robot-image   # ~10 min
    .venv/bin/python docs/experiments/tools/loom_search.py --jitters lgmd1/robot-image
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from lgmd_sim.benchmark.episode import Cell, episode
from lgmd_sim.controllers import options
from lgmd_sim.core.fileio import write_text_atomic
from lgmd_sim.core.jobs import Job
from lgmd_sim.core.parallel import RunOptions, run_jobs
from lgmd_sim.envs.zone import CRUISE, FALSE_ALARM_HORIZON
from lgmd_sim.signals.metrics import wilson_interval

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "docs/experiments/loom-search"
#: Search seeds: none of the benchmark's (20000 and up), training's (< 900), validation's
#: (900-949) or evaluation's (1000-1049).
SEEDS = range(2000, 2016)
SCENARIO, JITTER = "RoughTerrainObstacles", 1.0
#: The jitter levels of the parts' table (--jitters): the benchmark's goal track's.
JITTERS = (0.0, 1.0, 2.0)
#: The design ({}: LoomParams' defaults) and its variations.
SETTINGS: list[dict[str, float]] = [
    {}, {"steer_gain": 0.0}, {"steer_gain": 2.0}, {"memory": 0.0}, {"memory": 3.0},
    {"release": 0.3, "hold": 0.6}, {"release": 0.8, "hold": 0.2}, {"smooth": 0.25, "slow": 0.8},
]
#: The second round: variations of the first round's best (`second_round`).
SECOND: list[dict[str, float]] = [
    {"slow": 0.8}, {"smooth": 0.25}, {"memory": 1.0}, {"memory": 2.0}, {"avoid_speed": -0.3},
    {"eye_overlap": 0.4},
]
#: Not a candidate: the design with the video presets' alarm rule (4 frames above the
#: threshold, rising) at the robot preset's threshold, to see whether that rule helps.
ALARM_RULE = {"model_params": (("alarm_frames", 4), ("alarm_rising", True))}


def _cell(detector: str, setting: dict[str, float], jitter: float) -> Cell:
    from lgmd_sim import models

    model, preset = models.parse_spec(detector)
    return Cell(SCENARIO, jitter, "loom-steer", model, preset, tuple(sorted(setting.items())))


def second_round(best: dict[str, Any]) -> list[dict[str, Any]]:
    """The second round's settings: the first round's `best` with its steering gain 0.5
    either side (0.5 and 1.5 above a gain under 0.5: no setting run twice), or with one of
    `SECOND`."""
    gain = best.get("steer_gain", 1.0)
    gains = (gain - 0.5, gain + 0.5) if gain >= 0.5 else (gain + 0.5, gain + 1.5)
    return [{**best, "steer_gain": g} for g in gains] + [{**best, **v} for v in SECOND]


def _name(setting: dict[str, Any], jitter: float = JITTER) -> str:
    """A setting's name in the records: its values (and a jitter other than the search's),
    so that a setting two rounds share runs once."""
    name = json.dumps({k: dict(v) if k == "model_params" else v for k, v in setting.items()},
                      sort_keys=True)
    return name if jitter == JITTER else f"{name}-j{jitter:g}"


def _run(detector: str, settings: list[dict[str, Any]], records: dict[str, Any], path: Path,
         workers: int | None, jitters: Sequence[float] = (JITTER,)) -> None:
    """Every episode of `settings` (at each of `jitters`) not in `records`, each stored as
    it comes."""
    def store(job: Job, record: dict[str, Any]) -> None:
        records[job.key] = record
        write_text_atomic(path, json.dumps(records, indent=1))

    jobs = {f"{_name(setting, j)}-s{seed}": Job(
        f"{_name(setting, j)}-s{seed}", episode, {"cell": _cell(detector, setting, j),
                                                  "seed": seed, "resolution": "rl",
                                                  "cruise": CRUISE, "horizon": FALSE_ALARM_HORIZON})
            for j in jitters for setting in settings for seed in SEEDS}
    run_jobs([j for k, j in jobs.items() if k not in records], store,
             RunOptions(workers=workers), desc=detector)


def _rates(records: dict[str, Any], setting: dict[str, Any], jitter: float = JITTER
           ) -> tuple[int, int]:
    """Episodes of `setting` (at `jitter`) reaching the goal, and colliding."""
    got = [records[f"{_name(setting, jitter)}-s{seed}"] for seed in SEEDS]
    return sum(r["goal_reached"] for r in got), sum(r["collided"] for r in got)


def _pct(count: int) -> str:
    """A share of the seeds in percent, with its 95% Wilson interval."""
    low, high = wilson_interval(count, len(SEEDS))
    return f"{100 * count / len(SEEDS):.0f} [{100 * low:.0f}, {100 * high:.0f}]"


def _best(rows: list[tuple[int, dict[str, Any], int, int]]) -> tuple:
    return max(rows, key=lambda r: (r[2] - r[3], r[2]))


def _records(detector: str) -> tuple[Path, dict[str, Any]]:
    """Where `detector`'s records are kept, and those kept so far."""
    path = OUT / f"{options.file_key(detector).replace('/', '-')}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    return path, json.loads(path.read_text()) if path.exists() else {}


def search(detector: str, workers: int | None = None) -> tuple[str, dict[str, Any]]:
    """Run (or complete) the search for `detector`: its table (markdown) and its choice."""
    path, records = _records(detector)
    _run(detector, [*SETTINGS, ALARM_RULE], records, path, workers)
    rows = [(1, s, *_rates(records, s)) for s in SETTINGS]
    second = second_round(_best(rows)[1])
    _run(detector, second, records, path, workers)
    rows += [(2, s, *_rates(records, s)) for s in second]
    best = _best(rows)
    lines = [f"| {detector}: setting | round | success % | collisions % |",
             "|---|---:|---:|---:|"]
    lines += [f"| {s or 'as designed'}{' (chosen)' if row is best else ''} | {n} | "
              f"{_pct(a)} | {_pct(c)} |" for row in rows for n, s, a, c in [row]]
    a, c = _rates(records, ALARM_RULE)
    lines.append(f"| as designed, the video presets' alarm rule (4 frames, rising): no "
                 f"candidate | - | {_pct(a)} | {_pct(c)} |")
    return "\n".join(lines), best[1]


def parts(chosen: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """The chosen setting, and it without each part it uses: the memory, the steering
    between the eyes (where its gain is not 0 already)."""
    out = [("chosen", chosen), ("no memory", {**chosen, "memory": 0.0})]
    if chosen.get("steer_gain", 1.0) > 0:
        out.append(("no steering between the eyes", {**chosen, "steer_gain": 0.0}))
    return out


def by_jitter(detector: str, chosen: dict[str, Any], workers: int | None = None) -> str:
    """Run (or complete) `parts` of `chosen` at each of `JITTERS`: their table (markdown)."""
    path, records = _records(detector)
    settings = [s for _, s in parts(chosen)]
    _run(detector, settings, records, path, workers, JITTERS)
    head = " | ".join(f"j{j:g}: success % | j{j:g}: collisions %" for j in JITTERS)
    lines = [f"| {detector} | {head} |", "|---" + "|---:" * 2 * len(JITTERS) + "|"]
    for label, setting in parts(chosen):
        cells = [_pct(n) for j in JITTERS for n in _rates(records, setting, j)]
        lines.append(f"| {label} | {' | '.join(cells)} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("detectors", nargs="+", help="MODEL/PRESET, e.g. lgmd1/robot-image")
    parser.add_argument("--jitters", action="store_true",
                        help="then run the chosen setting's parts at jitter 0, 1 and 2")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    for detector in args.detectors:
        text, chosen = search(detector, args.workers)
        print(f"{text}\n\nchosen for {detector}: {chosen or 'as designed'} "
              f"(seeds {SEEDS.start}-{SEEDS.stop - 1})\n")
        if args.jitters:
            print(f"{by_jitter(detector, chosen, args.workers)}\n")


if __name__ == "__main__":
    main()
