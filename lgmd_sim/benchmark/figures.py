"""Figures of the closed-loop benchmark (the styles are lgmd_sim.core.plots'; those
of the open-loop benchmark are in `lgmd_sim.benchmark.open_loop_figures`).

A closed-loop run may hold many entries (cells: a controller with its detector; the robot's
presets make 19), too many for overlaid series told apart by colour. So the rates against
the jitter level are heatmaps with each value written in its cell, the example episodes are
small multiples (a panel per entry, every path in one colour), and the one scatter
(false alarms against collisions) numbers its points, coloured by model. An entry has the
same number in every figure of a run.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import models

# save_figure: the one name every closed-loop figure is written through, so that a test
# can catch them
from lgmd_sim.benchmark.drawing import draw_world, map_bounds, save_figure
from lgmd_sim.core.plots import figure, model_style

__all__ = ["ARENA_VS_JITTER", "CLOSED_LOOP", "closed_loop", "closed_loop_figures",
           "encounters_figure"]

#: The closed-loop benchmark's figures of every task.
CLOSED_LOOP = ("collisions_vs_jitter.png", "false_alarms_vs_collisions.png",
               "trajectories.png")
#: And of roam tasks (no goal): the avoidance rate, distance and false alarms against
#: jitter; and per scenario and jitter level a map of the example episodes' encounters
#: (`encounters_figure`).
ARENA_VS_JITTER = "arena_vs_jitter.png"


@dataclass(frozen=True)
class _Metric:
    """A heatmap panel: a summary row's value, its interval's key (None without one), what
    it is, why a panel may have none, and which way is better. A bounded value is read on
    0 to 1 (a rate; the ratio to the Oracle's distance, capped there), another on 0 to
    its panel's largest."""

    value: str
    ci: str | None
    what: str
    missing: str
    lower_is_better: bool
    bounded: bool = True


#: The panels of collisions_vs_jitter.png of a goal task and of a roam task (no success
#: without a goal: the share of encounters avoided instead), and of arena_vs_jitter.png.
_COLLISIONS = _Metric("collision_rate", "collision_ci", "collision rate", "", True)
_AVOIDANCE = _Metric("avoidance_rate", "avoidance_ci", "encounters avoided",
                     "no cell met an obstacle", False)
_GOAL_PANELS = (_COLLISIONS,
                _Metric("success_rate", "success_ci", "success rate", "", False))
_ROAM_PANELS = (_COLLISIONS, _AVOIDANCE)
_ARENA_PANELS = (_AVOIDANCE,
                 _Metric("distance_vs_oracle", None, "distance / the Oracle's",
                         "no Oracle cell ran", False),
                 _Metric("false_alarms_per_min", None, "false alarms per minute", "", True,
                         bounded=False))
#: The heatmaps' one colormap, read as worse (dark) to better (bright) in every panel.
_CMAP = "viridis"
#: An encounter's mark on the maps: avoided, and not (a collision).
_AVOIDED = {"marker": "o", "ms": 7, "mfc": "none", "mec": "#1b9e1b", "mew": 1.8,
            "ls": "none", "zorder": 5}
_FAILED = {"marker": "X", "ms": 8, "color": "#e0101a", "mec": "white", "mew": 0.6,
           "ls": "none", "zorder": 5}
#: Every path of the small multiples: one colour (a panel holds one entry).
_PATH = {"color": "#0072B2", "lw": 1.2, "zorder": 3}
_START = {"marker": "o", "ms": 4, "color": "#0072B2", "mec": "black", "mew": 0.5,
          "ls": "none", "zorder": 4}
_GOAL = {"marker": "*", "ms": 11, "color": "gold", "mec": "black", "mew": 0.6, "ls": "none",
         "zorder": 4}
#: The baselines' colours in the scatter (a detector's is its model's, lgmd_sim.core.plots'),
#: and those of other models and policies: none an Okabe-Ito colour of a model's, each
#: reading on white (contrast at least lgmd_sim.core.plots.MIN_CONTRAST).
_BASELINE_COLOURS = {"oracle": "black", "straight": "0.6"}
_EXTRA = ["#17BECF", "#882255", "#8C564B", "#9467BD", "#999933", "#56B4E9"]


def _entries(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The run's entries (cell labels) in the order of every figure, numbered from 1: the
    straight controller and the Oracle first (the baselines), then the others by name."""
    first = {r["cell"]: r for r in rows}
    fixed = sorted((c for c, r in first.items() if _is_baseline(r)), reverse=True)
    return fixed + sorted(set(first) - set(fixed))


def _is_baseline(row: dict[str, Any]) -> bool:
    """Whether a row is the straight controller's or the Oracle's (no detector, no tag)."""
    return not row["model"] and not row.get("tag") and row["controller"] in _BASELINE_COLOURS


def _colours(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Each entry's colour in the scatter: its model's (lgmd_sim.core.plots'; variants of a
    model share its hue, the number tells them apart), the baseline's, or for a model of
    another package or a policy one of `_EXTRA`, in turn, one per model or policy."""
    known = set(models.available())  # the built-in models: each has its own colour
    extra: dict[str, Any] = {}
    out = {}
    for r in sorted(rows, key=lambda r: r["cell"]):
        if _is_baseline(r):
            out[r["cell"]] = _BASELINE_COLOURS[r["controller"]]
        elif r["model"] in known:
            out[r["cell"]] = model_style(f"{r['model']}/{r['preset']}")["color"]
        else:
            key = r["model"] or r.get("tag") or r["cell"]
            out[r["cell"]] = extra.setdefault(key, _EXTRA[len(extra) % len(_EXTRA)])
    return out


def _ink(colour: Any) -> str:
    """Black or white, whichever reads on `colour`."""
    from matplotlib.colors import to_rgb

    r, g, b = to_rgb(colour)
    return "black" if 0.299 * r + 0.587 * g + 0.114 * b > 0.5 else "white"




def _is_goal(row: dict[str, Any]) -> bool:
    return row.get("task", "goal") == "goal"


def encounters_figure(scenario: str, jitter: float) -> str:
    """The name of the encounter map of a roam scenario at a jitter level."""
    return f"encounters_{scenario}_j{jitter:g}.png"


def closed_loop_figures(rows: Sequence[dict[str, Any]], examples: Sequence[dict[str, Any]]
                        ) -> tuple[str, ...]:
    """The names of the figures `closed_loop` writes from these rows and examples:
    `CLOSED_LOOP` (the trajectories only with top views), and where there are roam tasks
    `ARENA_VS_JITTER` and an encounter map per roam scenario and jitter level with a top
    view."""
    roam = {r["scenario"] for r in rows if not _is_goal(r)}
    names = list(CLOSED_LOOP if examples else CLOSED_LOOP[:2])
    if roam:
        names.append(ARENA_VS_JITTER)
        names += sorted({encounters_figure(e["scenario"], e["jitter"]) for e in examples
                         if e["scenario"] in roam})
    return tuple(names)


def closed_loop(folder: Path, rows: Sequence[dict[str, Any]],
                examples: Sequence[dict[str, Any]]) -> None:
    """The closed-loop figures (`closed_loop_figures`) from the summary rows and the
    records that carry a top view (the first seeds of each cell, each record with its row's
    "cell" label; an encounter map shows the first seed). A roam task (no goal, so no
    success) shows the share of encounters avoided where a goal task shows its success
    rate, and has figures of its own: the arena's rates and where each encounter
    happened."""
    scenarios = sorted({r["scenario"] for r in rows})
    roam = sorted({r["scenario"] for r in rows if not _is_goal(r)})
    entries = _entries(rows)
    _heatmaps(folder / CLOSED_LOOP[0], rows, entries,
              {sc: _ROAM_PANELS if sc in roam else _GOAL_PANELS for sc in scenarios})
    _false_alarms_vs_collisions(folder / CLOSED_LOOP[1], rows, scenarios, entries)
    if examples:
        _trajectories(folder / CLOSED_LOOP[2], examples, scenarios, entries)
    if roam:
        _heatmaps(folder / ARENA_VS_JITTER, [r for r in rows if r["scenario"] in roam],
                  entries, dict.fromkeys(roam, _ARENA_PANELS))
        first = min((e["seed"] for e in examples), default=None)  # a map shows one seed
        for sc in roam:
            for j in sorted({e["jitter"] for e in examples if e["scenario"] == sc}):
                _encounter_map(folder / encounters_figure(sc, j),
                               [e for e in examples if (e["scenario"], e["jitter"], e["seed"])
                                == (sc, j, first)], entries)


def _number(value: float, bounded: bool) -> str:
    return f"{value:.2f}" if bounded else f"{value:.3g}"


def _heatmaps(path: Path, rows: Sequence[dict[str, Any]], entries: list[str],
              panels: dict[str, Sequence[_Metric]]) -> None:
    """A row of panels per scenario (the keys of `panels`, each as many), one per metric:
    a heatmap of the entries (rows) against the jitter levels (columns), each cell with its
    value and, where it has one, its 95% Wilson interval written in, coloured from worse
    (dark) to better (bright); a cell without the value (no encounter, no Oracle to compare
    with) grey."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable

    jitters = sorted({r["jitter"] for r in rows})
    shown = [e for e in entries if any(r["cell"] == e for r in rows)]
    labels = [f"{e}  ({entries.index(e) + 1})" for e in shown]
    cmap = colormaps[_CMAP].with_extremes(bad="0.9")
    columns = len(next(iter(panels.values())))
    with_ci = any(m.ci for own in panels.values() for m in own)
    row_h = 0.36 if with_ci else 0.24  # inches: two lines of text, or one
    label_w = 0.075 * max(map(len, labels))  # inches, about, at the labels' size
    fig = figure(figsize=(label_w + 1.2 + columns * (0.25 + 1.1 * len(jitters)),
                          len(panels) * (row_h * len(shown) + 1.2)))
    axes = fig.subplots(len(panels), columns, squeeze=False)
    baselines = len({r["cell"] for r in rows if _is_baseline(r)})  # listed first
    for ax_row, (sc, own) in zip(axes, panels.items(), strict=True):
        by_cell = {(r["cell"], r["jitter"]): r for r in rows if r["scenario"] == sc}
        for ax, m in zip(ax_row, own, strict=True):
            values = np.array([[np.nan if (r := by_cell.get((e, j))) is None
                                or r[m.value] is None else r[m.value] for j in jitters]
                               for e in shown], float)
            top = 1.0 if m.bounded else max(1.0, float(np.nanmax(values, initial=0.0)))
            good = np.clip(values / top, 0, 1)
            good = 1 - good if m.lower_is_better else good
            ax.imshow(np.ma.masked_invalid(good), cmap=cmap, vmin=0, vmax=1, aspect="auto",
                      interpolation="nearest")
            if np.isnan(values).all() and m.missing:  # one note, not a grid of dashes
                ax.text(0.5, 0.5, m.missing, ha="center", va="center", color="0.3",
                        transform=ax.transAxes)
                values = values[:0]
            for (i, k), v in np.ndenumerate(values):
                r = by_cell.get((shown[i], jitters[k]))
                if np.isnan(v):
                    ax.text(k, i, "–" if r else "not run", ha="center", va="center",
                            color="0.4", fontsize="x-small")
                    continue
                ink = _ink(cmap(good[i, k]))
                ci = r[m.ci] if m.ci else None
                ax.text(k, i - 0.14 * bool(ci), _number(v, m.bounded), ha="center",
                        va="center", fontsize="small", color=ink, weight="bold")
                if ci:
                    ax.text(k, i + 0.25, f"{ci[0]:.2f}–{ci[1]:.2f}", ha="center",
                            va="center", fontsize=6.5, color=ink)
            if 0 < baselines < len(shown):  # the baselines apart from the entries
                ax.axhline(baselines - 0.5, color="white", lw=3)
            ax.set_xticks(range(len(jitters)), [f"{j:g}" for j in jitters])
            ax.set_xlabel("jitter level")
            ax.tick_params(length=0)
            better = "lower" if m.lower_is_better else "higher"
            ax.set_title(f"{sc}: {m.what}\n({better} is better"
                         f"{'; 95% Wilson CI below' if m.ci else ''})", fontsize="small")
            ax.set_yticks(range(len(shown)), labels if ax is ax_row[0] else [])
    bar = fig.colorbar(ScalarMappable(cmap=cmap), ax=axes, ticks=[0, 1], shrink=0.4,
                       aspect=15, location="right")
    bar.ax.set_yticklabels(["worse", "better"])
    save_figure(fig, path)


def _spread(points: np.ndarray, gap: float) -> np.ndarray:
    """The (n, 2) `points` (in units where a marker is `gap` wide) nudged apart until no two
    are closer than `gap`, each as little as it takes, so that every marker and its number
    shows near its place."""
    n = len(points)
    turn = 2 * np.pi * np.arange(n) / max(n, 1)
    # where two coincide, the way apart is their turns' around a circle
    around = np.c_[np.cos(turn), np.sin(turn)]
    out = points.astype(float)
    others = 1 - np.eye(n)
    for _ in range(1000):
        apart = out[:, None] - out[None]
        distance = np.linalg.norm(apart, axis=-1)
        overlap = np.clip(gap - distance, 0, None) * others
        if overlap.max(initial=0) < 1e-3 * gap:
            break
        same = (distance < 1e-9 * gap)[..., None]
        way = np.where(same, around[:, None] - around[None], apart)
        way /= np.linalg.norm(way, axis=-1, keepdims=True) + np.eye(n)[..., None]
        # each of a pair that overlaps moves half the overlap away from the other, the
        # moves of one with many overlaps averaged (summed, a crowd would scatter it far)
        crowd = np.maximum((overlap > 0).sum(axis=1, keepdims=True), 1)
        out += (way * overlap[..., None] / 2).sum(axis=1) / crowd
    return out


def _false_alarms_vs_collisions(path: Path, rows: Sequence[dict[str, Any]],
                                scenarios: list[str], entries: list[str]) -> None:
    """One panel per scenario and jitter level: each entry's false alarms per minute and
    collision rate, or for a roam task collisions per minute (over a fixed time nearly
    every episode touches something: its collision rate is about 1 for every entry); each
    point a disc with the entry's number in its model's colour, points that coincide
    spread around their place."""
    from matplotlib.lines import Line2D

    jitters = sorted({r["jitter"] for r in rows})
    fig = figure(figsize=(3.4 * len(jitters) + 3.4, 3.2 * len(scenarios) + 0.4))
    axes = fig.subplots(len(scenarios), len(jitters), squeeze=False, sharex=True,
                        sharey="row")
    span = max(1.0, max(r["false_alarms_per_min"] for r in rows))
    values = {}
    for i, sc in enumerate(scenarios):
        own = [r for r in rows if r["scenario"] == sc]
        values[sc] = (("collision_rate", "collision rate") if _is_goal(own[0])
                      else ("collisions_per_min", "collisions per minute"))
        top = max(1.0, *(r[values[sc][0]] for r in own))
        axes[i, 0].set_ylim(-0.12 * top, 1.13 * top)
        axes[i, 0].set_ylabel(values[sc][1])
        for ax, j in zip(axes[i], jitters, strict=True):
            ax.set_title(f"{sc}, jitter {j:g}", fontsize="medium")
            ax.grid(alpha=0.3)
    axes[0, 0].set_xlim(-0.08 * span, 1.08 * span)
    for ax in axes[-1]:
        ax.set_xlabel("false alarms per minute")
    # from the left: centred on the figure, a narrow one's title ran under the legend
    fig.suptitle("The cost of avoiding (lower left is better)", fontsize="medium", x=0.02,
                 ha="left")
    colours = _colours(rows)
    handles = [Line2D([], [], label=f"{k}  {e}", marker="o", ms=8, color=colours[e],
                      mec="black", mew=0.6, ls="none")
               for k, e in enumerate(entries, 1) if e in colours]
    fig.legend(handles=handles, loc="outside right upper", fontsize="small",
               title="number: the entry; colour: its model\n(points that coincide are "
               "spread\naround their place)", title_fontsize="x-small", alignment="left")
    # the layout (legend and titles in place), hence each panel's size in inches
    fig.draw_without_rendering()
    size = 13.0  # points: a disc's width
    for i, sc in enumerate(scenarios):
        value = values[sc][0]
        for ax, j in zip(axes[i], jitters, strict=True):
            cells = sorted((r for r in rows if (r["scenario"], r["jitter"]) == (sc, j)),
                           key=lambda r: entries.index(r["cell"]))
            box = ax.get_window_extent()
            per_inch = np.array([np.ptp(ax.get_xlim()) / box.width,
                                 np.ptp(ax.get_ylim()) / box.height]) * fig.dpi
            if cells:
                at = _spread(np.array([[r["false_alarms_per_min"], r[value]]
                                       for r in cells]) / per_inch, size / 72) * per_inch
                for r, (x, y) in zip(cells, at, strict=True):
                    colour = colours[r["cell"]]
                    # not clipped: a disc nudged past the axes' edge still shows whole
                    ax.plot(x, y, marker="o", ms=size, color=colour, mec="black", mew=0.6,
                            ls="none", zorder=3, clip_on=False)
                    ax.text(x, y, str(entries.index(r["cell"]) + 1), ha="center",
                            va="center_baseline", fontsize=6.5, color=_ink(colour),
                            zorder=4, clip_on=False)
    save_figure(fig, path)


def _map_panel(ax, record: dict[str, Any], box: np.ndarray) -> np.ndarray:
    """One entry's episode from above on `ax`, limited to `box`: the world, the path from
    its start, the goal; returns the path."""
    view = record["top_view"]
    draw_world(ax, view)
    xy = np.array(view["path"]).reshape(-1, 2)
    ax.plot(*xy.T, **_PATH)
    ax.plot(*xy[0], **_START)
    if view["goal"]:
        ax.plot(*view["goal"], **_GOAL)
    (x0, y0), (x1, y1) = box
    ax.set(xlim=(x0, x1), ylim=(y0, y1), aspect="equal", xticks=[], yticks=[])
    return xy


def _map_legend(fig, marks: Sequence[tuple[str, dict[str, Any]]]) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], label="path", **_PATH), Line2D([], [], label="start", **_START),
               *(Line2D([], [], label=label, **style) for label, style in marks)]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles),
               fontsize="small")


def _trajectories(path: Path, examples: Sequence[dict[str, Any]], scenarios: list[str],
                  entries: list[str]) -> None:
    """Small multiples of the episodes with a top view: a row per entry and a column per
    world (scenario, seed and jitter level), each panel the entry's path from above in
    one colour, its first collision and the goal; the panels of a scenario share its
    extent."""
    worlds = sorted({(r["scenario"], r["seed"], r["jitter"]) for r in examples},
                    key=lambda w: (scenarios.index(w[0]), w[1], w[2]))
    shown = [e for e in entries if any(r["cell"] == e for r in examples)]
    by = {(r["cell"], r["scenario"], r["seed"], r["jitter"]): r for r in examples}
    boxes = {}
    for sc in {w[0] for w in worlds}:
        own = [map_bounds([r]) for r in examples if r["scenario"] == sc]
        boxes[sc] = np.array([np.min([b[0] for b in own], axis=0),
                              np.max([b[1] for b in own], axis=0)])
    # each column as wide as its scenario's extent at one row height (equal axes)
    height = 1.5
    widths = [float(np.clip(height * np.divide(*np.diff(boxes[sc], axis=0)[0]), 0.8, 3.0))
              for sc, *_ in worlds]
    labels = [f"{e}  ({entries.index(e) + 1})" for e in shown]
    label_w = 0.065 * max(map(len, labels))  # inches, about, at the labels' size
    fig = figure(figsize=(sum(widths) + 0.1 * len(widths) + label_w + 0.3,
                          (height + 0.08) * len(shown) + 1.3))
    fig.get_layout_engine().set(w_pad=0.02, h_pad=0.02, wspace=0.0, hspace=0.0)
    axes = fig.subplots(len(shown), len(worlds), squeeze=False, width_ratios=widths)
    for i, e in enumerate(shown):
        for k, (sc, seed, j) in enumerate(worlds):
            ax = axes[i, k]
            if i == 0:
                ax.set_title(f"{sc}\njitter {j:g}, seed {seed}", fontsize="x-small")
            if k == 0:
                ax.set_ylabel(labels[i], rotation=0, ha="right", va="center",
                              fontsize="small")
            record = by.get((e, sc, seed, j))
            if record is None:  # no top view of this entry here
                ax.set(xticks=[], yticks=[])
                for spine in ax.spines.values():
                    spine.set_visible(False)
                continue
            xy = _map_panel(ax, record, boxes[sc])
            hit = record["top_view"]["collision_frame"]
            if hit is not None:
                ax.plot(*xy[hit], **_FAILED)
    sizes = " and ".join(f"{sc} {np.ptp(b[:, 0]):.0f} m × {np.ptp(b[:, 1]):.0f} m"
                         for sc, b in sorted(boxes.items()))
    fig.suptitle(f"Each entry's example episodes from above (obstacles brown, terrain grey; "
                 f"a panel spans {sizes})", fontsize="medium")
    _map_legend(fig, [("first collision", _FAILED), ("goal", _GOAL)])
    save_figure(fig, path)


def _encounter_map(path: Path, examples: Sequence[dict[str, Any]], entries: list[str]
                   ) -> None:
    """A roam scenario at one jitter level from above, small multiples of a panel per
    entry: the world, the example episode's path from its start, and each encounter where
    it began, avoided or not."""
    group = sorted(examples, key=lambda r: entries.index(r["cell"]))
    box = map_bounds(group)
    cols = min(5, len(group))
    rows_n = -(-len(group) // cols)
    width = 2.2  # inches per panel; its height follows the extent (equal axes)
    (x0, y0), (x1, y1) = box
    height = float(np.clip(width * (y1 - y0) / (x1 - x0), 1.0, 4.0))
    fig = figure(figsize=(width * cols + 0.3, (height + 0.45) * rows_n + 0.8))
    axes = fig.subplots(rows_n, cols, squeeze=False).ravel()
    for ax, r in zip(axes, group, strict=False):
        _map_panel(ax, r, box)
        marks = r["top_view"].get("encounters", [])
        for x, y, avoided in marks:
            ax.plot(x, y, **(_AVOIDED if avoided else _FAILED))
        kept = sum(m[2] for m in marks)
        # long labels (a plug-in's module path) wrapped to the panel's width
        ax.set_title(f"{textwrap.fill(r['cell'], 32)}:\n{kept} of {len(marks)} avoided",
                     fontsize="small")
    for ax in axes[len(group):]:
        ax.axis("off")
    first = group[0]
    fig.suptitle(f"{first['scenario']}, jitter {first['jitter']:g}, seed {first['seed']}: "
                 f"where each encounter began ({x1 - x0:.0f} m × {y1 - y0:.0f} m)",
                 fontsize="medium")
    _map_legend(fig, [("encounter avoided", _AVOIDED),
                      ("encounter with a collision", _FAILED)])
    save_figure(fig, path)
