"""The closed-loop benchmark's summary (`lgmd_sim.benchmark.closed_loop`): one row per cell
from its episodes' records (`lgmd_sim.benchmark.episode`), rates with 95% Wilson intervals,
and the tables episodes.csv, summary.csv and summary.md."""

from __future__ import annotations

import statistics
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.benchmark import encounters
from lgmd_sim.benchmark.episode import Cell
from lgmd_sim.core.fileio import csv_text, write_text_atomic
from lgmd_sim.signals import metrics

__all__ = ["cell_of", "summarise", "summary_markdown", "write_tables"]


def cell_of(record: dict[str, Any]) -> Cell:
    """The cell of an episode's record, as far as its label goes (not a policy's path)."""
    side = record["side"]
    return Cell(record["scenario"], record["jitter"], record["controller"], record["model"],
                record["preset"], (("side", side),) if side else (), record["tag"])


def _median(values: Sequence[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return statistics.median(kept) if kept else None


def _mean(values: Sequence[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else None


def summarise(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per cell: rates with 95% Wilson intervals, false alarms per minute, median
    first-alarm time to collision and lead time, mean distance travelled; for goal tasks
    the success rate and mean progress; where the records count them (all but those from
    before the arena task) collisions per minute, the share of the pooled encounters
    avoided, the mean distance relative to the Oracle's (the untagged oracle cell of the
    same scenario and jitter level, over the seeds both have a distance for; None without
    one) and the mean share of the time spent manoeuvring (None where the controller
    cannot tell)."""
    groups: dict[tuple, list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        groups[(r["scenario"], r["jitter"], r["controller"], r["model"], r["preset"],
                r["tag"], r["side"])].append(r)
    rows = []
    for (sc, j, ctrl, model, preset, tag, side), rs in groups.items():
        n = len(rs)
        goal = rs[0]["task"] == "goal"
        collided = sum(r["collided"] for r in rs)
        reached = sum(r["goal_reached"] for r in rs)
        minutes = sum(r["time_s"] for r in rs) / 60
        progress = [r["progress"] for r in rs if r.get("progress") is not None]
        counted = all("encounters" in r for r in rs)
        met = sum(r["encounters"] for r in rs) if counted else 0
        avoided = sum(r["avoided"] for r in rs) if counted else 0
        rows.append({
            "scenario": sc, "jitter": j, "controller": ctrl, "model": model, "preset": preset,
            "tag": tag, "side": side, "task": "goal" if goal else "roam",
            "cell": cell_of(rs[0]).label, "episodes": n,
            "collision_rate": collided / n, "collision_ci": metrics.wilson_interval(collided, n),
            "success_rate": reached / n if goal else None,
            "success_ci": metrics.wilson_interval(reached, n) if goal else None,
            "false_alarms_per_min": sum(r["false_alarms"] for r in rs) / minutes,
            "median_first_alarm_ttc_s": _median([r["first_alarm_ttc_s"] for r in rs]),
            "median_lead_time_s": _median([r["lead_time_s"] for r in rs]),
            "mean_progress": float(np.mean(progress)) if progress else None,
            "mean_time_s": float(np.mean([r["time_s"] for r in rs])),
            "mean_distance_m": _mean([r["distance_m"] for r in rs]),
            "collisions": sum(r["collisions"] for r in rs) if counted else None,
            "collisions_per_min": (sum(r["collisions"] for r in rs) / minutes
                                   if counted else None),
            "encounters": met if counted else None,
            "avoided": avoided if counted else None,
            "avoidance_rate": avoided / met if met else None,
            "avoidance_ci": metrics.wilson_interval(avoided, met) if met else None,
            "manoeuvring_share": _mean([r.get("manoeuvring_share") for r in rs]),
        })
    # the Oracle: the planned cell, untagged (an extra cell with parameters has a tag)
    distances = {key: {r["seed"]: r["distance_m"] for r in rs} for key, rs in groups.items()}
    for key, row in zip(groups, rows, strict=True):
        base = distances.get((*key[:2], "oracle", None, None, None, None), {})
        row["distance_vs_oracle"] = _paired_ratio(distances[key], base)
    return rows


def _paired_ratio(values: dict[int, float | None], base: dict[int, float | None]
                  ) -> float | None:
    """The mean of `values` over the mean of `base` (each by seed), over the seeds both
    have a value for; None without one, or where the base's is 0."""
    seeds = [s for s, v in values.items() if v is not None and base.get(s) is not None]
    below = sum(base[s] for s in seeds)
    return sum(values[s] for s in seeds) / below if below else None


_EPISODE_COLUMNS = ["scenario", "jitter", "controller", "model", "preset", "tag", "side",
                    "seed", "task", "frames",
                    "time_s", "collided", "goal_reached", "distance_m", "straight_line_m",
                    "path_ratio", "progress", "alarms", "false_alarms", "false_alarms_per_min",
                    "first_alarm_ttc_s", "lead_time_s", "min_clearance_m", "collisions",
                    "collisions_per_min", "encounters", "avoided", "manoeuvring_share"]
#: summary.csv's columns: every row has them all, empty where they do not apply.
_SUMMARY_COLUMNS = ["scenario", "jitter", "controller", "model", "preset", "tag", "side",
                    "task", "episodes", "collision_rate", "collision_ci_low",
                    "collision_ci_high", "success_rate", "success_ci_low", "success_ci_high",
                    "false_alarms_per_min", "median_first_alarm_ttc_s", "median_lead_time_s",
                    "mean_progress", "mean_time_s", "mean_distance_m", "distance_vs_oracle",
                    "collisions", "collisions_per_min", "encounters", "avoided",
                    "avoidance_rate", "avoidance_ci_low", "avoidance_ci_high",
                    "manoeuvring_share"]


def _fmt(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def _percent(rate: float | None, ci: tuple[float, float] | None) -> str:
    """A rate in percent with its 95% interval, "-" where there is none."""
    if rate is None or ci is None:
        return "-"
    return f"{100 * rate:.0f} [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]"


def _percent_of(share: float | None) -> str:
    return "-" if share is None else f"{100 * share:.0f}"


_GOAL_LEGEND = ("_collisions, success: shares of the episodes with a collision and reaching "
                "the goal (95% Wilson intervals); false alarm: an alarm onset with no "
                "obstacle within the horizon's time to collision; lead time: from the last "
                "alarm onset to the collision; progress: share of the way to the goal "
                "covered._")
_ROAM_LEGEND = (f"_{encounters.LEGEND}; avoided %: of the cell's pooled encounters (95% "
                "Wilson interval, too narrow: encounters cluster by episode); collisions / "
                "min: collision onsets; false alarm: an alarm onset with no obstacle "
                "within the horizon's time to collision; distance vs Oracle: mean distance "
                "travelled over the Oracle's on the seeds both have; manoeuvring: share of "
                "the time braking and turning away (-: the controller cannot tell)._")


def summary_markdown(rows: Sequence[dict[str, Any]]) -> str:
    """The summary as Markdown: a table of the goal tasks' cells and one of the roam
    tasks' (rates in percent with their 95% intervals), each with its legend."""
    goal = [r for r in sorted(rows, key=_order) if r["task"] == "goal"]
    roam = [r for r in sorted(rows, key=_order) if r["task"] == "roam"]
    blocks = []
    if goal:
        lines = ["| scenario | jitter | controller | episodes | collisions % [95% CI] | "
                 "success % [95% CI] | false alarms / min | first alarm TTC (s, median) | "
                 "lead time (s, median) | progress |",
                 "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['scenario']} | {r['jitter']:g} | {r['cell']} | {r['episodes']} | "
                  f"{_percent(r['collision_rate'], r['collision_ci'])} | "
                  f"{_percent(r['success_rate'], r['success_ci'])} | "
                  f"{_fmt(r['false_alarms_per_min'])} | "
                  f"{_fmt(r['median_first_alarm_ttc_s'])} | "
                  f"{_fmt(r['median_lead_time_s'])} | {_fmt(r['mean_progress'])} |"
                  for r in goal]
        blocks += ["\n".join(lines), _GOAL_LEGEND]
    if roam:
        lines = ["| scenario | jitter | controller | episodes | encounters | "
                 "avoided % [95% CI] | collisions / min | false alarms / min | "
                 "distance (m, mean) | distance vs Oracle | manoeuvring % |",
                 "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        lines += [f"| {r['scenario']} | {r['jitter']:g} | {r['cell']} | {r['episodes']} | "
                  f"{'-' if r['encounters'] is None else r['encounters']} | "
                  f"{_percent(r['avoidance_rate'], r['avoidance_ci'])} | "
                  f"{_fmt(r['collisions_per_min'])} | {_fmt(r['false_alarms_per_min'])} | "
                  f"{_fmt(r['mean_distance_m'])} | {_fmt(r['distance_vs_oracle'])} | "
                  f"{_percent_of(r['manoeuvring_share'])} |" for r in roam]
        blocks += ["\n".join(lines), _ROAM_LEGEND]
    return "\n\n".join(blocks) + "\n"


def _order(r: dict[str, Any]) -> tuple:
    rank = {"oracle": 0, "reactive": 1, "straight": 2}.get(r["controller"], 1)
    return (r["scenario"], r["jitter"], rank, r["cell"])


def write_tables(folder: Path, records: Sequence[dict[str, Any]],
                 rows: Sequence[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """episodes.csv, summary.csv and summary.md from the records (and their summary,
    when it is made already); return the summary."""
    rows = summarise(records) if rows is None else list(rows)

    def bounds(r: dict[str, Any], what: str) -> dict[str, float | None]:
        low, high = r[f"{what}_ci"] or (None, None)
        return {f"{what}_ci_low": low, f"{what}_ci_high": high}

    flat = [{**r, **bounds(r, "collision"), **bounds(r, "success"), **bounds(r, "avoidance")}
            for r in sorted(rows, key=_order)]
    write_text_atomic(folder / "episodes.csv", csv_text(records, _EPISODE_COLUMNS))
    write_text_atomic(folder / "summary.csv", csv_text(flat, _SUMMARY_COLUMNS))
    write_text_atomic(folder / "summary.md", summary_markdown(rows))
    return rows
