"""The record of benchmark protocol v2 (docs/experiments/protocol-v2.md), from the rows'
result files: each row's wall time, the intervals it gives beside v1's, how the detection
track ranks the detector rows against their driving (v2's camera track and its synthetic
stimuli, v1's detection), the camera's ceiling and each entry's dose-response.

    python docs/experiments/tools/protocol_v2.py [--out docs/experiments/protocol-v2.md]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from lgmd_sim.benchmark import scores
from lgmd_sim.benchmark.leaderboard import against_driving, parts

ROOT = Path(__file__).resolve().parents[3]
V1, V2 = ROOT / "docs/benchmark/runs", ROOT / "docs/benchmark/v2/runs"
SMOKE = ROOT / "docs/experiments/protocol-v2/smoke-result.json"


def _results(folder: Path) -> dict[str, dict]:
    return {r["entry"]["label"]: r for r in (
        json.loads(f.read_text()) for f in sorted(folder.glob("*/result.json")))}


def _half(r: dict, key: str) -> float | None:
    if key not in r["intervals"]:
        return None
    low, high = r["intervals"][key]
    return (high - low) / 2


def _f(v: float | None, digits: int = 2) -> str:
    return "-" if v is None or (isinstance(v, float) and np.isnan(v)) else f"{v:.{digits}f}"


def page() -> str:
    v1, v2 = _results(V1), _results(V2)
    rel = "docs/experiments/tools/protocol_v2.py"
    lines = ["# Benchmark protocol v2: its record", "",
             f"Made by `python {rel}` from the rows' result files "
             "(docs/benchmark/v2/runs, v1's docs/benchmark/runs). What the user reads is "
             "[the benchmark guide](../guides/benchmark.md) and "
             "[the leaderboard](../leaderboard.md); this page keeps the figures behind "
             "protocol v2's choices.", "",
             f"Rows so far: {len(v2)} under v2, {len(v1)} under v1.", ""]

    lines += ["## Does detection predict driving?", "",
              "Spearman's rank correlation between a track's score and the overall (driving) "
              "score, over the detector rows (target 0.7 or more):", "",
              "| protocol | track | rows | Spearman |", "|---|---|---:|---:|"]
    for name, results, tracks in (("v1", v1, ("detection",)),
                                  ("v2", v2, ("detection", "stimuli"))):
        for track in tracks:
            got = against_driving(list(results.values()), track)
            what = {"detection": "detection (synthetic clips)" if name == "v1" else
                    "detection (robot camera)", "stimuli": "stimuli (synthetic clips)"}[track]
            lines.append(f"| {name} | {what} | {got[1] if got else 0} | "
                         f"{_f(got[0]) if got else '-'} |")

    lines += ["", "## The camera's ceiling", "",
              "The Oracle reacts to every obstacle; view-oracle to those the camera sees; "
              "the best LGMD row to its own alarms. Goal track, all levels pooled:", "",
              "| entry | overall | goal | arena | success % | collisions % |",
              "|---|---|---|---|---:|---:|"]
    detectors = [r for r in v2.values() if r["entry"]["kind"] == "detector"]
    best = max(detectors, key=lambda r: r["scores"]["overall"], default=None)
    for label in ("oracle", "view-oracle", *([best["entry"]["label"]] if best else [])):
        r = v2.get(label)
        if r is None:
            continue
        goal = r["metrics"]["goal"].values()
        lines.append(f"| `{label}` | {_f(r['scores']['overall'])} | {_f(r['scores']['goal'])} "
                     f"| {_f(r['scores']['arena'])} "
                     f"| {100 * np.mean([m['success_rate'] for m in goal]):.0f} "
                     f"| {100 * np.mean([m['collision_rate'] for m in goal]):.0f} |")

    lines += ["", "## Dose-response", "",
              "Each entry's overall score (a policy's: its goal score) by jitter level, and "
              "J50 (where it halves, with its 95% interval; inf: not within the levels):", ""]
    doses = {k: scores.dose_response(parts(r), 2000, 0) for k, r in v2.items()}
    levels = next((d["levels"] for d in doses.values() if d), [])
    within = [k for k, d in doses.items() if d and np.isfinite(d["j50"])]
    lines += [f"J50 lies within the levels for {len(within)} of {len(doses)} entries "
              f"({', '.join(f'`{k}`' for k in sorted(within)) or 'none'}): up to jitter "
              f"{levels[-1]:g} most scores do not halve, and the floors' rise with it (the "
              "rough ground deflects a robot that would drive into an obstacle).", ""]
    lines += ["| entry | " + " | ".join(f"j{j:g}" for j in levels) + " | J50 |",
              "|---|" + "---:|" * len(levels) + "---|"]
    for label, d in sorted(doses.items(), key=lambda kv: -kv[1]["scores"][0] if kv[1] else 0):
        if d is None:
            continue
        low, high = d["j50_interval"]
        lines.append(f"| `{label}` | " + " | ".join(_f(s) for s in d["scores"])
                     + f" | {_f(d['j50'], 1)} [{_f(low, 1)}, {_f(high, 1)}] |")

    ratios = [_half(r, "overall") / _half(v1[k], "overall") for k, r in v2.items()
              if k in v1 and _half(v1[k], "overall") and _half(r, "overall")]
    lines += ["", "## Interval widths and wall times", "",
              "Half-widths of the 95% intervals, v2 (20 seeds x 6 levels a track) beside v1 "
              "(40 seeds x 3 levels) for the entries both have; each v2 row's wall time and "
              "processor."]
    if ratios:
        lines += [f"Over the {len(ratios)} entries both have, v2's overall interval is "
                  f"{np.median(ratios):.2f} times v1's (median; {min(ratios):.2f} to "
                  f"{max(ratios):.2f}): the price of the three levels more it scores."]
    lines += ["", "| entry | overall v1 | overall v2 | goal v1 | goal v2 | arena v1 | arena v2 "
              "| v2 wall time (min) | processor |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for label, r in sorted(v2.items()):
        old = v1.get(label, {"intervals": {}})
        cells = [_f(_half(x, k), 3) for k in ("overall", "goal", "arena") for x in (old, r)]
        lines.append(f"| `{label}` | " + " | ".join(cells)
                     + f" | {r['timing']['wall_time_s'] / 60:.1f} | {r['machine'].get('cpu')} |")
    if SMOKE.is_file():
        smoke = json.loads(SMOKE.read_text())
        lines += ["", "## The smoke mode", "",
                  f"`{smoke['command']}` from a clean clone: "
                  f"{smoke['timing']['wall_time_s']:.0f} s on {smoke['machine'].get('cpu')} "
                  f"({SMOKE.relative_to(ROOT / 'docs/experiments')}: its result)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs/experiments/protocol-v2.md")
    args = parser.parse_args()
    args.out.write_text(page())
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
