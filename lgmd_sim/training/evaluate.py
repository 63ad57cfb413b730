"""`lgmd-sim eval`: trained policies in the closed-loop benchmark, beside the hand-made
controllers, on the same seeds.

Each policy is a cell of its own (``Cell(scenario, jitter, "policy", params=(("path",
...),), tag=<policy name>)``) added to the benchmark's sweep (`lgmd_sim.bench.closed_loop`),
so it writes the same tables and figures; ``eval.md`` adds the mean distance travelled.
Every cell runs in the environment the policies were trained in (their scenario and frame
size), so the policies must share both.
"""

from __future__ import annotations

import argparse
import csv
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

from lgmd_sim.fileio import write_text_atomic

__all__ = ["eval_markdown", "evaluate"]


def evaluate(args: argparse.Namespace) -> int:
    """Check the policies and every list, then run the benchmark with the policies' cells."""
    from lgmd_sim import controllers
    from lgmd_sim.bench import closed_loop
    from lgmd_sim.bench.cli import parse_detectors, parse_jitter, parse_names
    from lgmd_sim.envs.catalogue import scenarios
    from lgmd_sim.extras import require
    from lgmd_sim.training.policy import load_config, name_of

    require("stable_baselines3", "rl")
    loaded = [load_config(p) for p in args.policies or ["shipped"]]
    names = [name_of(folder) for folder, _, _ in loaded]
    if len(set(names)) < len(names):
        raise ValueError(f"two policies share a folder name ({', '.join(names)}): the name "
                         "labels a policy's cells")
    envs = {(c.env_id, str(c.resolution)) for _, c, _ in loaded}
    if len(envs) > 1:
        raise ValueError("the policies were trained in different environments or frame sizes "
                         f"({'; '.join(' at '.join(e) for e in sorted(envs))}): evaluate them "
                         "apart")
    config = loaded[0][1]
    by_id = {s.env_id: name for name, s in scenarios().items()}
    if config.env_id not in by_id:
        raise ValueError(f"policy {names[0]} was trained in {config.env_id}, which is not a "
                         "scenario of the catalogue (lgmd-sim envs lists them)")
    hand_made = [c for c in controllers.available() if c != "policy"]
    args.controllers = ([] if args.controllers.strip() == "none" else
                        parse_names(args.controllers, hand_made, "controller(s)"))
    args.detectors = parse_detectors(args.models, args.presets)
    args.jitter = parse_jitter(args.jitter)
    args.scenarios = [by_id[config.env_id]]
    args.resolution = config.resolution
    if not (-1 <= args.cruise <= 1):
        raise ValueError(f"--cruise must be in [-1, 1], got {args.cruise}")
    if not (math.isfinite(args.horizon) and args.horizon > 0):
        raise ValueError(f"--horizon must be a number > 0, got {args.horizon}")
    extra = [closed_loop.Cell(args.scenarios[0], j, "policy",
                              params=(("path", str(folder.resolve())),), tag=name)
             for j in args.jitter for (folder, _, _), name in zip(loaded, names, strict=True)]
    code = closed_loop.run(args, extra)
    out = Path(args.out)
    write_text_atomic(out / "eval.md", eval_markdown(out))
    print(f"wrote {out}/eval.md")
    return code


def eval_markdown(folder: Path) -> str:
    """Per cell of the benchmark run in `folder`: collision and success rates (95%
    intervals) and the mean distance travelled, from its summary.csv and episodes.csv; the
    reactive cell with the fewest collisions (then the most successes) at each jitter
    level is marked as the best detector."""
    distance: dict[tuple[str, str], list[float]] = defaultdict(list)
    with (folder / "episodes.csv").open(newline="") as f:
        for r in csv.DictReader(f):
            distance[(r["jitter"], _label(r))].append(float(r["distance_m"]))
    with (folder / "summary.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    best = {}
    for r in rows:
        if r["controller"] == "reactive":
            score = (-float(r["collision_rate"]), float(r["success_rate"]))
            if r["jitter"] not in best or score > best[r["jitter"]][0]:
                best[r["jitter"]] = (score, _label(r))
    lines = ["| jitter | controller | episodes | collisions % [95% CI] | success % [95% CI] "
             "| distance travelled (m, mean) | progress |", "|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        label = _label(r)
        mark = " (best detector)" if best.get(r["jitter"], (0, None))[1] == label else ""
        d = distance[(r["jitter"], label)]
        lines.append(
            f"| {float(r['jitter']):g} | {label}{mark} | {r['episodes']} | "
            f"{_pct(r, 'collision')} | {_pct(r, 'success')} | {sum(d) / len(d):.2f} | "
            f"{_fmt(r['mean_progress'])} |")
    return "\n".join(lines) + "\n"


def _label(r: dict[str, Any]) -> str:
    from lgmd_sim.bench.closed_loop import Cell

    return Cell(r["scenario"], float(r["jitter"]), r["controller"], r["model"] or None,
                r["preset"] or None, tag=r["tag"] or None).label


def _pct(r: dict[str, str], what: str) -> str:
    rate, lo, hi = (float(r[f"{what}_rate"]), float(r[f"{what}_ci_low"]),
                    float(r[f"{what}_ci_high"]))
    return f"{100 * rate:.0f} [{100 * lo:.0f}, {100 * hi:.0f}]"


def _fmt(text: str) -> str:
    return f"{float(text):.2f}" if text else "-"
