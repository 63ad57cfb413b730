"""The leaderboard: results of one protocol version (`lgmd_sim.benchmark.run`'s
``result.json``) merged into one ranked Markdown table and its figures.

Entries rank by their overall score; each is compared with the one ranked above it,
paired on the seeds (`lgmd_sim.benchmark.scores.compare`), and marked "=" where the
interval of the difference holds 0: the two are not separable on these seeds. Under
protocol 2 the table also gives each entry's J50 (the jitter level at which its score
halves) and, over the detector rows, how well the detection score ranks them as their
driving does (Spearman's rank correlation); a second figure draws every entry's score
against jitter, and the synthetic stimuli get a table of their own.
"""

from __future__ import annotations

import html
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.benchmark import audit, scores
from lgmd_sim.benchmark.protocol import Protocol
from lgmd_sim.core.fileio import atomic_outputs
from lgmd_sim.core.params import FieldError
from lgmd_sim.core.runs import NUMBER, Maybe, read_record

__all__ = ["RESULT_FIELDS", "against_driving", "leaderboard", "load_result", "markdown",
           "parts", "spearman"]

#: What the leaderboard reads of a result.
RESULT_FIELDS = {
    "protocol": {"version": int, "sha256": str},
    "entry": {"spec": str, "kind": str, "label": str, "controller": Maybe(str),
              "model": Maybe(str), "preset": Maybe(str), "side": Maybe(str),
              "policy": Maybe(str)},
    "scores": {"goal": NUMBER, "arena": Maybe(NUMBER), "overall": Maybe(NUMBER),
               "detection": Maybe(NUMBER), "stimuli": Maybe(NUMBER)},
    "intervals": dict,
    "metrics": {"goal": dict, "arena": Maybe(dict), "detection": Maybe(dict),
                "stimuli": Maybe(dict)},
    "parts": {t: Maybe({"seeds": [int], "sums": [[NUMBER]], "levels": Maybe([NUMBER])})
              for t in scores.TRACKS},
    "command": str,
    "machine": dict,
    "timing": {"wall_time_s": NUMBER},
}


def load_result(path: str | Path, protocol: Protocol | None = None) -> dict[str, Any]:
    """A result file (or an entry's folder holding one), its shape checked; with
    `protocol`, also that it is a result of that protocol whose every number its parts
    hold (`lgmd_sim.benchmark.audit.check`).

    Raises:
        ValueError: one that cannot be read, is not a benchmark result, is another
            protocol's or claims what its parts do not hold (one line naming it).
    """
    path = Path(path)
    file = path / "result.json" if path.is_dir() else path
    result = read_record(file, RESULT_FIELDS, "give the result.json files that lgmd-sim "
                         "benchmark writes (OUT/ENTRY/result.json)")
    if protocol is None:
        return result
    if result["protocol"].get("smoke"):
        raise ValueError(f"{file}: a smoke result (lgmd-sim benchmark --smoke, a handful of "
                         "seeds), not ranked beside full rows")
    identity = protocol.identity()
    if result["protocol"] != identity:
        raise ValueError(f"{file}: a result of another protocol (version "
                         f"{result['protocol']['version']}, {result['protocol']['sha256'][:12]}) "
                         f"than {protocol.name} ({identity['sha256'][:12]}): a leaderboard "
                         "merges one protocol's results (--protocol names theirs)")
    try:
        audit.check(result, protocol)
    except ValueError as exc:
        raise ValueError(f"{file}: {exc}; not ranked") from None
    return result


def parts(result: Mapping[str, Any]) -> dict[str, scores.Parts]:
    """A result's per-seed parts by track, as `lgmd_sim.benchmark.scores.compare` takes them."""
    return {t: scores.Parts.from_json(p) for t, p in result["parts"].items() if p}


def _printable(text: str) -> str:
    """`text` on one line: a control character (a newline) as its escape, so that no value
    starts another row."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _code(text: str, cell: bool = True) -> str:
    """`text` as a Markdown code span, fenced by more backticks than it holds in a row; in
    a table's `cell`, its pipes escaped (a pipe ends a cell even within a span)."""
    text = _printable(text)
    if cell:
        text = text.replace("|", "\\|")
    fence = "`" * (1 + max((len(run) for run in re.findall("`+", text)), default=0))
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def _plain(text: str) -> str:
    """`text` as plain Markdown: no HTML, link, emphasis or cell of its own."""
    text = html.escape(_printable(text), quote=False)
    return re.sub(r"([\\`*\[\]|])", r"\\\1", text)


def _cell(result: Mapping[str, Any], key: str) -> str:
    """A score with its interval: "0.61 [0.52, 0.70]", or "-"."""
    value = result["scores"].get(key)
    if value is None:
        return "-"
    low, high = result["intervals"][key]
    return f"{value:.2f} [{low:.2f}, {high:.2f}]"


def _order(results: Sequence[Mapping[str, Any]]) -> list[int]:
    """The indices of `results` best first: by overall score, then (those without one) by
    goal score."""
    def rank(i: int) -> tuple:
        s = results[i]["scores"]
        return (s.get("overall") is None, -(s.get("overall") or s["goal"]),
                results[i]["entry"]["label"])

    return sorted(range(len(results)), key=rank)


def _pooled(result: Mapping[str, Any], track: str, column: str) -> str:
    """The mean over the jitter levels of a track's per-level `column`, as a percentage."""
    values = [row[column] for row in (result["metrics"].get(track) or {}).values()
              if row.get(column) is not None]
    return f"{100 * float(np.mean(values)):.0f}" if values else "-"


def _level(value: float, levels: Sequence[float]) -> str:
    """A J50 or an end of its interval: beyond the last level is "> last"."""
    return f">{levels[-1]:g}" if np.isinf(value) else f"{value:.1f}"


def _j50(result: Mapping[str, Any], resamples: int, seed: int) -> str:
    """An entry's J50 with its interval, "-" where its jitter-0 score is 0 or its parts do
    not hold the levels apart."""
    dose = scores.dose_response(parts(result), resamples, seed)
    if dose is None or np.isnan(dose["j50"]):
        return "-"
    low, high = dose["j50_interval"]
    shown = [_level(v, dose["levels"]) for v in (dose["j50"], low, high)]
    return f"{shown[0]} [{shown[1]}, {shown[2]}]"


def spearman(x: Sequence[float], y: Sequence[float]) -> float:
    """Spearman's rank correlation of `x` and `y` (ties take their mean rank)."""
    def ranks(v: Sequence[float]) -> np.ndarray:
        v = np.asarray(v, float)
        order = np.argsort(v, kind="stable")
        r = np.empty(len(v))
        r[order] = np.arange(len(v), dtype=float)
        for value in np.unique(v):  # ties: their mean rank
            r[v == value] = r[v == value].mean()
        return r

    return float(np.corrcoef(ranks(x), ranks(y))[0, 1])


def against_driving(results: Sequence[Mapping[str, Any]], track: str = "detection"
                    ) -> tuple[float, int] | None:
    """How `track`'s score ranks the rows that have it and an overall score (the detector
    rows) against their driving: Spearman's correlation with the overall score, and the
    rows counted; None with fewer than 3."""
    rows = [r for r in results if r["scores"].get(track) is not None
            and r["scores"].get("overall") is not None]
    if len(rows) < 3:
        return None
    return spearman([r["scores"][track] for r in rows],
                    [r["scores"]["overall"] for r in rows]), len(rows)


def _prediction(results: Sequence[Mapping[str, Any]]) -> str:
    """How the detection track ranks the detector rows against their driving, in words."""
    found = against_driving(results)
    if found is None:
        return ""
    rho, n = found
    return (f"Detection against driving: over the {n} detector rows, the detection "
            f"score ranks them as the overall score does with a Spearman correlation of "
            f"{rho:.2f}.\n\n")


def _stimuli_table(results: Sequence[Mapping[str, Any]], order: Sequence[int]) -> list[str]:
    """The synthetic stimuli's table (protocol 2), outside the overall score."""
    rows = [results[i] for i in order if results[i]["scores"].get("stimuli") is not None]
    if not rows:
        return []
    lines = ["", "Synthetic stimuli (the paper's kind of clips, version 1's detection track; "
             "outside the overall score):", "",
             "| entry | stimuli | hits % | false alarms % | AUC |", "|---|---|---:|---:|---:|"]
    for r in rows:
        m = r["metrics"]["stimuli"]
        auc = "-" if m.get("auc") is None else f"{m['auc']:.2f}"
        lines.append(f"| {_code(r['entry']['label'])} | {_cell(r, 'stimuli')} "
                     f"| {100 * m['hit_rate']:.0f} | {100 * m['false_alarm_rate']:.0f} "
                     f"| {auc} |")
    return lines


def markdown(results: Sequence[Mapping[str, Any]], names: Sequence[str],
             resamples: int, seed: int) -> str:
    """The ranked table of `results` (their files' `names`, for the commands' list); those
    without an overall score (a policy: no arena) unranked, after the others."""
    order = _order(results)
    # parts per jitter level (J50) are protocol 2's, whose detection is the robot camera's
    dose = camera = any(p.get("levels") for r in results for p in r["parts"].values() if p)
    lines = ["| rank | entry | overall | goal | arena | detection | "
             + ("J50 | " if dose else "")
             + "success % | collisions % | avoided % | false alarms / min | AUC |",
             "|---:|---|---|---|---|---|" + ("---|" if dose else "")
             + "---:|---:|---:|---:|---:|"]
    above: list[Mapping[str, Any]] = []
    rank = 1
    for i in order:
        r = results[i]
        ranked = r["scores"].get("overall") is not None
        # A rank counts only the entries better beyond doubt (paired on the seeds), so that
        # a chain of close neighbours does not carry one rank down the table.
        separable = [scores.compare(parts(r), parts(a), resamples, seed)["overall"][
            "separable"] for a in above] if ranked else []
        tied = bool(separable) and not separable[-1]
        rank = max(rank, 1 + sum(separable))  # never above an entry higher in the table
        shown = ("=" if tied else "") + str(rank) if ranked else "-"
        auc = (r["metrics"].get("detection") or {}).get("auc")
        alarms = np.mean([row["false_alarms_per_min"] for row in r["metrics"]["goal"].values()
                          if row.get("false_alarms_per_min") is not None] or [np.nan])
        lines.append(
            f"| {shown} | {_code(r['entry']['label'])} | {_cell(r, 'overall')} "
            f"| {_cell(r, 'goal')} | {_cell(r, 'arena')} | {_cell(r, 'detection')} "
            + (f"| {_j50(r, resamples, seed)} " if dose else "")
            + f"| {_pooled(r, 'goal', 'success_rate')} | {_pooled(r, 'goal', 'collision_rate')} "
            f"| {_pooled(r, 'arena', 'avoidance_rate')} "
            f"| {'-' if np.isnan(alarms) else f'{alarms:.1f}'} "
            f"| {'-' if auc is None else f'{auc:.2f}'} |")
        if ranked:
            above.append(r)
    detection = ("detection (on the robot's camera: the mean of approach clips alarmed in "
                 "the manoeuvre's window, clear clips silent, window frames alarmed and "
                 "clear frames silent)" if camera else
                 "detection (balanced accuracy on looming and non-looming clips)")
    lines += ["", "_Rank: 1 + the entries above that are better beyond their interval (paired "
              "on the seeds); '=': not separable from the entry just above. Scores in [0, 1] "
              "with 95% intervals: goal (SPL), arena (encounters avoided "
              f"x distance over the Oracle's), {detection}, overall (mean of goal and arena). "
              + ("J50: the jitter level at which the overall score (a policy's: the goal's) "
                 "falls to half its jitter-0 score, linear between levels ('>3': not within "
                 "them; '-': a jitter-0 score of 0). " if dose else "")
              + "Success, collisions and false alarms: the goal track's, averaged over its "
              "jitter levels; avoided: the arena's encounters; AUC: the detection clips' "
              "frames. Unranked (-): no arena (a policy observes a goal)._",
              *_stimuli_table(results, order),
              "", "Rows' commands, wall time and machine:", ""]
    for i in order:
        r = results[i]
        cpu = str(r["machine"].get("cpu", "?"))
        lines.append(f"- {_code(r['entry']['label'])} ({_plain(names[i])}): "
                     f"{_code(r['command'] or '?', cell=False)}, "
                     f"{r['timing']['wall_time_s'] / 60:.0f} min on {_plain(cpu)}")
    return "\n".join(lines) + "\n"


def _figure(results: Sequence[Mapping[str, Any]], file: Path) -> None:
    """Score by entry: overall, each closed-loop track's by jitter level, detection, as a
    heatmap, best entry on top."""
    from lgmd_sim.core.plots import figure

    order = [results[i] for i in _order(results)]
    # a track no result ran (the arena, among policies alone) has no column
    levels = {t: sorted(next(r["metrics"][t] for r in order if r["metrics"].get(t)), key=float)
              for t in scores.CLOSED_LOOP if any(r["metrics"].get(t) for r in order)}
    columns = [("overall", None), *((t, j) for t in levels for j in levels[t]),
               ("detection", None)]
    grid = np.full((len(order), len(columns)), np.nan)
    for row, r in enumerate(order):
        for col, (t, j) in enumerate(columns):
            if j is None:
                value = r["scores"].get(t)
                grid[row, col] = np.nan if value is None else value
            elif r["metrics"].get(t):
                grid[row, col] = r["metrics"][t][j]["score"]
    fig = figure(figsize=(2.2 + 0.75 * len(columns), 1.0 + 0.38 * len(order)))
    ax = fig.add_subplot()
    image = ax.imshow(np.ma.masked_invalid(grid), cmap="viridis", vmin=0, vmax=1,
                      aspect="auto")
    for (row, col), v in np.ndenumerate(grid):
        if not np.isnan(v):
            ax.text(col, row, f"{v:.2f}", ha="center", va="center", fontsize=8,
                    color="white" if v < 0.6 else "black")
    ax.set_xticks(range(len(columns)),
                  [f"{t}\njitter {j}" if j is not None else t for t, j in columns], fontsize=8)
    ax.set_yticks(range(len(order)), [r["entry"]["label"] for r in order], fontsize=8)
    ax.set_title("Score by track and jitter level (grey: not run)", fontsize=9)
    ax.set_facecolor("0.85")
    ax.axvline(0.5, color="white", lw=3)  # the headline apart from what makes it
    fig.colorbar(image, ax=ax, shrink=0.8, label="score")
    fig.savefig(file, dpi=120)


#: The dose-response figure's panels: which entries each draws.
_PANELS = ("references and baselines", "detectors driving the reference controller",
           "other controllers and policies")


def _panel(result: Mapping[str, Any]) -> int:
    entry = result["entry"]
    if entry["kind"] == "controller" or str(entry.get("model") or "").startswith(
            "lgmd_sim.benchmark.baselines"):
        return 0
    if entry["kind"] == "detector" and entry.get("controller") in (None, "reactive") and (
            entry.get("side") or "halves") == "halves":
        return 1
    return 2


def _dose_figure(results: Sequence[Mapping[str, Any]], doses: Sequence[Any], file: Path
                 ) -> None:
    """Every entry's overall score (a policy's: its goal score) against jitter, one panel a
    kind of entry, each entry's J50 marked where the curve halves."""
    from matplotlib import colormaps

    from lgmd_sim.core.plots import figure

    panels: list[list[int]] = [[] for _ in _PANELS]
    for i in _order(results):
        if doses[i] is not None:
            panels[_panel(results[i])].append(i)
    used = [k for k, members in enumerate(panels) if members]
    fig = figure(figsize=(5.2 * len(used), 4.6))
    axes = fig.subplots(1, len(used), sharey=True, squeeze=False)[0]
    for ax, k in zip(axes, used, strict=True):
        n = len(panels[k])  # no colour twice in a panel
        colours = colormaps["tab10" if n <= 10 else "tab20"].colors[:n]
        for colour, i in zip(colours, panels[k], strict=True):
            d = doses[i]
            ax.plot(d["levels"], d["scores"], marker="o", ms=3, color=colour,
                    label=results[i]["entry"]["label"])
            if np.isfinite(d["j50"]):
                ax.plot(d["j50"], d["scores"][0] / 2, marker="x", ms=7, color=colour)
        ax.set_title(_PANELS[k], fontsize=9)
        ax.set_xlabel("jitter level")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2,
                  frameon=False)
    axes[0].set_ylabel("overall score (policies: goal)")
    fig.suptitle("Score against jitter (x: J50, where the score halves)", fontsize=10)
    fig.savefig(file, dpi=120, bbox_inches="tight")


def leaderboard(paths: Sequence[str | Path], out: str | Path, protocol: Protocol
                ) -> list[Path]:
    """Merge the results at `paths`, each of `protocol`, into the Markdown table `out` and
    its figure (``out`` with .png); return the files written.

    Raises:
        ValueError: no results, a file that is no result, a result of another protocol
            (version or digest), or two of one entry (one line naming them).
    """
    if not paths:
        raise ValueError("no results given")
    out = Path(out)
    if out.suffix != ".md" or out.is_dir():
        raise FieldError("out", "must be a FILE.md, the table (its figure goes beside it, "
                         f"FILE.png), got {str(out)!r}")
    results = [load_result(p, protocol) for p in paths]
    first = protocol.identity()
    labels = [r["entry"]["label"] for r in results]
    twice = sorted({label for label in labels if labels.count(label) > 1})
    if twice:
        raise ValueError(f"two results of entry {twice[0]!r}: give each entry once")
    figure_file = out.with_suffix(".png")
    resamples, seed = protocol.bootstrap, protocol.bootstrap_seed
    doses = [scores.dose_response(parts(r), resamples, seed) for r in results]
    dose_file = out.with_name(f"{out.stem}-jitter.png") if any(doses) else None
    header = (f"# Leaderboard\n\nProtocol {protocol.name} (sha256 {first['sha256'][:12]}); "
              f"95% intervals over {resamples} bootstrap resamples of the seeds; '=' marks "
              "an entry not separable from the one above it (paired on the seeds).\n\n"
              f"![Score by entry, track and jitter level]({figure_file.name})\n\n"
              + (f"![Score against jitter, every entry]({dose_file.name})\n\n"
                 if dose_file else "")
              + _prediction(results))
    table = markdown(results, [str(p) for p in paths], resamples, seed)
    files = [out, figure_file, *([dose_file] if dose_file else [])]
    with atomic_outputs(files) as made:
        made[0].write_text(header + table)
        _figure(results, made[1])
        if dose_file:
            _dose_figure(results, doses, made[2])
    return files
