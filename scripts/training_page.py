"""The results section of docs/training.md, and the shipped policy's folder, from training
and evaluation runs: every table and figure made from the runs' files, every sentence's
figures computed from them, each run's command beside its results.

    .venv/bin/python scripts/training_page.py --train runs/train/sac-feedback \
        runs/train/sac-lgmd1 --eval runs/eval-190k --bench runs/closed-loop \
        runs/closed-loop-calibrated \
        --ship runs/train/sac-feedback

--bench: closed-loop benchmark runs on the same scenario and seeds (supersets of the
evaluation's), whose ReactiveAvoid cell with the fewest collisions (then the most
successes) stands beside the policies, on the evaluation's seeds only. --ship copies that
training run's final policy into lgmd_sim/policies/ with a POLICY.md (its command and its
rows of the table).
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
from collections import defaultdict
from pathlib import Path

from lgmd_sim.metrics import wilson_interval
from lgmd_sim.policies import DEFAULT

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "training.md"
FIGURES = ROOT / "docs" / "training"
RESULTS = "## Results"


def _episodes(run: Path) -> list[dict[str, str]]:
    with (run / "episodes.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def _label(r: dict[str, str]) -> str:
    if r.get("tag"):
        return f"{r['controller']}: {r['tag']}"
    return f"{r['controller']}: {r['model']}/{r['preset']}" if r["model"] else r["controller"]


def _cells(rows: list[dict[str, str]]) -> dict[tuple[float, str], dict[str, float]]:
    """Per (jitter, controller label): episodes, collisions, successes, mean distance."""
    groups: dict[tuple[float, str], list[dict[str, str]]] = defaultdict(list)
    for r in rows:
        groups[(float(r["jitter"]), _label(r))].append(r)
    return {key: {"n": len(rs), "collided": sum(r["collided"] == "True" for r in rs),
                  "reached": sum(r["goal_reached"] == "True" for r in rs),
                  "distance": sum(float(r["distance_m"]) for r in rs) / len(rs),
                  "progress": sum(float(r["progress"]) for r in rs) / len(rs)}
            for key, rs in groups.items()}


def _rate(k: int, n: int) -> str:
    lo, hi = wilson_interval(k, n)
    return f"{100 * k / n:.0f} [{100 * lo:.0f}, {100 * hi:.0f}]"


def _best_reactive(benches: list[Path]) -> dict[float, str]:
    """Per jitter level, the benches' reactive cell with the fewest collisions, then the
    most successes, each over all its run's seeds."""
    cells = {k: v for bench in benches
             for k, v in _cells([r for r in _episodes(bench)
                                 if r["controller"] == "reactive"]).items()}
    best: dict[float, tuple[tuple[float, float], str]] = {}
    for (jitter, label), c in cells.items():
        score = (-c["collided"] / c["n"], c["reached"] / c["n"])
        if jitter not in best or score > best[jitter][0]:
            best[jitter] = (score, label)
    return {j: label for j, (_, label) in best.items()}


def table(eval_run: Path, benches: list[Path]) -> tuple[list[str], dict, dict[float, str]]:
    """The evaluation's cells and the benches' best reactive cell on the same seeds: the
    Markdown table, the cells, and the best cell's label per jitter level."""
    rows = _episodes(eval_run)
    seeds, jitters = {r["seed"] for r in rows}, {float(r["jitter"]) for r in rows}
    best = {j: cell for j, cell in _best_reactive(benches).items() if j in jitters}
    have = {(float(r["jitter"]), _label(r)) for r in rows}
    for bench in benches:  # the best cell on the evaluation's seeds, unless it ran there too
        rows += [r for r in _episodes(bench) if r["seed"] in seeds
                 and r["controller"] == "reactive" and _label(r) == best.get(float(r["jitter"]))
                 and (float(r["jitter"]), _label(r)) not in have]
    cells = _cells(rows)
    lines = ["| jitter | controller | episodes | collisions % [95% CI] | successes % [95% CI] "
             "| distance travelled (m, mean) | progress to the goal (mean) |",
             "|---:|---|---:|---:|---:|---:|---:|"]
    for (jitter, label), c in sorted(cells.items()):
        mark = " (best detector)" if best.get(jitter) == label else ""
        lines.append(f"| {jitter:g} | {label}{mark} | {c['n']} | "
                     f"{_rate(c['collided'], c['n'])} | {_rate(c['reached'], c['n'])} | "
                     f"{c['distance']:.2f} | {c['progress']:.2f} |")
    return lines, cells, best


def reading(cells: dict, best: dict[float, str], policies: list[str], trained_at: float
            ) -> list[str]:
    """Sentences from the table: each policy against the best reactive detector, and the
    policies against each other at the training jitter and at the others."""
    out = []
    for jitter in sorted({j for j, _ in cells}):
        ref = cells.get((jitter, best.get(jitter, "")))
        for name in policies:
            c = cells[(jitter, f"policy: {name}")]
            text = (f"- jitter {jitter:g}{' (trained)' if jitter == trained_at else ' (unseen)'}"
                    f", {name}: {100 * c['collided'] / c['n']:.0f}% collisions, "
                    f"{100 * c['reached'] / c['n']:.0f}% successes, {c['distance']:.1f} m "
                    "travelled")
            if ref is not None:
                fewer = c["collided"] / c["n"] <= ref["collided"] / ref["n"]
                more = c["reached"] / c["n"] > ref["reached"] / ref["n"]
                text += (f"; ReactiveAvoid with {best[jitter].split(': ')[1]}: "
                         f"{100 * ref['collided'] / ref['n']:.0f}% and "
                         f"{100 * ref['reached'] / ref['n']:.0f}%. Target (no more collisions "
                         f"and more successes): {'met' if fewer and more else 'not met'}")
            out.append(text + ".")
    if len(policies) == 2:  # the two feature sets against each other, level by level
        a, b = policies
        for jitter in sorted({j for j, _ in cells}):
            ca, cb = cells[(jitter, f"policy: {a}")], cells[(jitter, f"policy: {b}")]
            verdict = "the same successes, collisions and progress"
            for word, value in (("more successes", lambda c: c["reached"] / c["n"]),
                                ("fewer collisions", lambda c: -c["collided"] / c["n"]),
                                ("more progress to the goal", lambda c: c["progress"])):
                x, y = value(ca), value(cb)
                if x != y:
                    verdict = f"{a if x > y else b} does better ({word})"
                    break
            out.append(f"- {a} against {b} at jitter {jitter:g}: {verdict}.")
    return out


def _summary(run: Path) -> str:
    return (run / "summary.md").read_text().strip().split("\n", 1)[1].strip()


def _copy(src: Path, name: str) -> str:
    FIGURES.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, FIGURES / name)
    return f"training/{name}"


def ship(run: Path, eval_lines: list[str], name: str = DEFAULT) -> Path:
    folder = ROOT / "lgmd_sim" / "policies" / name
    folder.mkdir(parents=True, exist_ok=True)
    for f in ("policy.zip", "policy.json"):
        shutil.copyfile(run / f, folder / f)
    command = json.loads((run / "run.json").read_text())["sessions"][0]["command"]
    tag = f"policy: {run.name}"
    mine = [line.replace(tag, f"policy: {name}") for line in eval_lines[2:] if tag in line]
    (folder / "POLICY.md").write_text(
        f"# {name}\n\nTrained by\n\n```bash\n{command}\n```\n\n{_summary(run)}\n\n"
        "Evaluated on held-out seeds by `lgmd-sim eval` (all rows: docs/training.md):\n\n"
        + "\n".join([*eval_lines[:2], *mine]) + "\n")
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--train", type=Path, nargs="+", required=True)
    parser.add_argument("--eval", type=Path, required=True)
    parser.add_argument("--bench", type=Path, nargs="*", default=[])
    parser.add_argument("--ship", type=Path)
    args = parser.parse_args()
    lines = [RESULTS, "",
             "All on the development machine (a 2-core Xeon VM, no GPU, Mesa software GL), "
             "shared with other jobs during some sessions: steps per second vary by 20 to 30 "
             "percent from run to run, more under load. Made by `scripts/training_page.py` "
             "from the runs; every figure below is the runs' own.", "", "### Training runs",
             ""]
    trained_at = None
    for run in args.train:
        record = json.loads((run / "run.json").read_text())
        trained_at = record["options"]["jitter"]
        lines += ["```bash", *(s["command"] for s in record["sessions"]), "```", "",
                  _summary(run), "",
                  f"![learning curve of {run.name}]"
                  f"({_copy(run / 'learning_curve.png', f'learning_curve_{run.name}.png')})",
                  ""]
    evaluation = json.loads((args.eval / "run.json").read_text())
    rows, cells, best = table(args.eval, args.bench)
    names = [c["tag"] for c in evaluation["config"]["extra"]]
    policies = list(dict.fromkeys(names))
    lines += ["### Evaluation on held-out seeds", "", "```bash", evaluation["command"]]
    lines += [json.loads((b / "run.json").read_text())["command"] for b in args.bench]
    lines += ["```", "",
              "Seeds from 1000, never used in training (0 and up) or validation (900 and "
              "up). ReactiveAvoid's best detector is the one with the fewest collisions (then "
              "the most successes) over all the closed-loop benchmark's seeds at that jitter "
              "level, shown here on the evaluation's seeds.", "", *rows, "",
              *reading(cells, best, policies, trained_at), ""]
    for fig in ("collisions_vs_jitter.png", "trajectories.png"):
        lines += [f"![{fig}]({_copy(args.eval / fig, fig)})", ""]
    text = PAGE.read_text()
    head = text[:text.index(f"\n{RESULTS}\n") + 1] if RESULTS in text else text.rstrip() + "\n\n"
    PAGE.write_text(head + "\n".join(lines).rstrip() + "\n")
    print(f"wrote {PAGE.relative_to(ROOT)} and {FIGURES.relative_to(ROOT)}/")
    if args.ship is not None:
        print(f"shipped {ship(args.ship, rows).relative_to(ROOT)}")


if __name__ == "__main__":
    main()
