"""Figures of the model benchmark (the styles are lgmd_sim.plots')."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import metrics
from lgmd_sim.fileio import write_files
from lgmd_sim.plots import figure, model_style

__all__ = ["ARENA_VS_JITTER", "CLOSED_LOOP", "closed_loop", "closed_loop_figures",
           "draw_world", "encounters_figure", "map_bounds", "open_loop"]

#: The closed-loop benchmark's figures of every task.
CLOSED_LOOP = ("collisions_vs_jitter.png", "false_alarms_vs_collisions.png",
               "trajectories.png")
#: And of roam tasks (no goal): the avoidance rate, distance and false alarms against
#: jitter; and per scenario and jitter level a map of the example episodes' encounters
#: (`encounters_figure`).
ARENA_VS_JITTER = "arena_vs_jitter.png"
#: The panels of collisions_vs_jitter.png of a goal task and of a roam task (no success
#: without a goal: the share of encounters avoided instead), and of arena_vs_jitter.png:
#: (value, its interval, what it is, why a panel may have none).
_GOAL_PANELS = (("collision_rate", "collision_ci", "collision rate", ""),
                ("success_rate", "success_ci", "success rate", ""))
_AVOIDED_PANEL = ("avoidance_rate", "avoidance_ci", "encounters avoided",
                  "no cell met an obstacle")
_ROAM_PANELS = (_GOAL_PANELS[0], _AVOIDED_PANEL)
_ARENA_PANELS = (_AVOIDED_PANEL,
                 ("distance_vs_oracle", None, "distance travelled / the Oracle's",
                  "no Oracle cell ran"),
                 ("false_alarms_per_min", None, "false alarms per minute", ""))
#: An encounter's mark on the maps: avoided, and not (a collision).
_AVOIDED = {"marker": "o", "ms": 10, "mfc": "none", "mec": "#1b9e1b", "mew": 2.2,
            "ls": "none", "zorder": 5}
_FAILED = {"marker": "X", "ms": 11, "color": "#e0101a", "mec": "white", "mew": 0.8,
           "ls": "none", "zorder": 5}
_CONTROLLER_STYLES = {
    "oracle": {"color": "black", "ls": "-", "marker": "s"},
    "straight": {"color": "0.6", "ls": (0, (1, 1)), "marker": "D"},
}
#: The other cells' colours, in turn: matplotlib's tab10 without its grey (the straight
#: controller's) and its brown (the obstacles'), so that no two cells of a run look alike
#: before the ninth; markers and dashes vary too, so that the ninth still differs.
_PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#e377c2", "#bcbd22",
            "#17becf"]
_MARKERS = ["o", "^", "v", "P", "h", "<", ">", "p", "d"]
_DASHES = ["-", (0, (5, 1.5)), (0, (6, 1.5, 1.5, 1.5))]
#: Line width and marker size of a cell, and their growth per cell drawn after it on the
#: same place: lines or points that coincide nest (the last drawn, narrowest, on top).
_LW, _LW_STEP = 1.6, 1.5
_MS, _MS_STEP = 7.0, 3.5
#: How far apart neighbouring cells' points stand at a jitter level (share of the span).
_DODGE = 0.012
#: Margin of the trajectory panels around the paths, obstacles and goal (m).
_PAD = 0.4


def _styles(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Each cell's colour, dashes and marker, the same in every figure of the run, and its
    rank (``k``, 0 for the first drawn, of ``n``)."""
    first = {r["cell"]: r for r in rows}
    fixed = sorted((c for c, r in first.items() if not r["model"] and not r.get("tag")
                    and r["controller"] in _CONTROLLER_STYLES), reverse=True)
    others = sorted(set(first) - set(fixed))
    styles = {cell: dict(_CONTROLLER_STYLES[first[cell]["controller"]]) for cell in fixed}
    for i, cell in enumerate(others):
        styles[cell] = {"color": _PALETTE[i % len(_PALETTE)],
                        "ls": _DASHES[i // len(_PALETTE) % len(_DASHES)],
                        "marker": _MARKERS[i % len(_MARKERS)]}
    # straight, oracle, then the rest: the baselines at the bottom
    for k, cell in enumerate(styles):
        styles[cell].update(k=k, n=len(styles))
    return styles


def _covers(shapes: Sequence[np.ndarray], tolerance: float) -> list[np.ndarray]:
    """For each (n, 2) array of points, in drawing order: per point, how many of the arrays
    drawn after it pass within `tolerance` of it (would hide it there): its widening."""
    def near(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (np.linalg.norm(a[:, None] - b[None], axis=-1) < tolerance).any(axis=1)

    return [np.sum([near(a, b) for b in shapes[i + 1:]], axis=0, dtype=int)
            * np.ones(len(a), int) for i, a in enumerate(shapes)]


def _line(style: dict[str, Any], widen: int) -> dict[str, Any]:
    """Matplotlib line arguments of a cell under `widen` lines that coincide with it (solid
    then: the stripe around the narrower lines on top)."""
    return {"color": style["color"], "ls": style["ls"] if widen == 0 else "-",
            "lw": _LW + _LW_STEP * widen,
            "zorder": 2 + style["k"] / style["n"], "solid_capstyle": "butt"}


def _point(style: dict[str, Any], widen: int) -> dict[str, Any]:
    """Matplotlib marker arguments of a cell under `widen` points that coincide with it."""
    return {"marker": style["marker"], "ms": _MS + _MS_STEP * widen, "color": style["color"],
            "mec": "black", "mew": 0.6, "ls": "none", "zorder": 3 + style["k"] / style["n"]}


def _legend(fig, styles: dict[str, dict[str, Any]], note: str, lines: bool) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], label=cell, color=st["color"], ls=st["ls"] if lines else "none",
                      lw=_LW + 0.4, marker=st["marker"], ms=7, mec="black", mew=0.6)
               for cell, st in styles.items()]
    # as many columns as it takes to fit the figure's height (a "small" entry takes
    # about 0.22 in): with many cells one column runs off the bottom
    rows = max(1, int((fig.get_figheight() - 0.8) / 0.22))
    fig.legend(handles=handles, loc="outside right upper", fontsize="small",
               ncols=math.ceil(len(handles) / rows), title=note, title_fontsize="x-small",
               alignment="left")


def _save(fig, path: Path) -> None:
    # tight: an equal-aspect panel beside an outside legend otherwise clips its y label
    write_files({path: lambda tmp: fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")})


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
    "cell" label; an encounter map shows the first seed);
    each cell has one style in every figure. A roam task (no goal, so no success) shows
    the share of encounters avoided where a goal task shows its success rate, and has
    figures of its own: the arena's rates and where each encounter happened."""
    scenarios = sorted({r["scenario"] for r in rows})
    roam = sorted({r["scenario"] for r in rows if not _is_goal(r)})
    styles = _styles(rows)
    _vs_jitter(folder / CLOSED_LOOP[0], rows, styles,
               {sc: _ROAM_PANELS if sc in roam else _GOAL_PANELS for sc in scenarios})
    _false_alarms_vs_collisions(folder / CLOSED_LOOP[1], rows, scenarios, styles)
    if examples:
        _trajectories(folder / CLOSED_LOOP[2], examples, scenarios, styles)
    if roam:
        _vs_jitter(folder / ARENA_VS_JITTER, [r for r in rows if r["scenario"] in roam],
                   styles, dict.fromkeys(roam, _ARENA_PANELS))
        first = min((e["seed"] for e in examples), default=None)  # a map shows one seed
        for sc in roam:
            for j in sorted({e["jitter"] for e in examples if e["scenario"] == sc}):
                _encounter_map(folder / encounters_figure(sc, j),
                               [e for e in examples if (e["scenario"], e["jitter"], e["seed"])
                                == (sc, j, first)], styles)


def _vs_jitter(path: Path, rows: Sequence[dict[str, Any]], styles: dict[str, dict[str, Any]],
               panels: dict[str, Sequence[tuple[str, str | None, str, str]]]) -> None:
    """A row of panels per scenario (the keys of `panels`, each as many), one per (value,
    interval, name, why it may be missing) of its panels: each cell's value against the
    jitter level, with its 95% Wilson interval where it has one. A panel spans 0 to 1
    (rates, ratios up to 1) or to its largest value."""
    columns = len(next(iter(panels.values())))
    fig = figure(figsize=(5.5 * columns, 3.6 * len(panels)))
    axes = fig.subplots(len(panels), columns, squeeze=False)
    span = max(1.0, np.ptp([r["jitter"] for r in rows]))
    for ax_row, (sc, own) in zip(axes, panels.items(), strict=True):
        lines: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for r in sorted(rows, key=lambda r: (list(styles).index(r["cell"]), r["jitter"])):
            if r["scenario"] == sc:
                lines[r["cell"]].append(r)
        # each cell a little to the side of its jitter level, so that error bars of equal
        # rates stand side by side
        dodge = {cell: (k - (len(lines) - 1) / 2) * _DODGE * span
                 for k, cell in enumerate(lines)}
        for ax, (value, ci, what, missing) in zip(ax_row, own, strict=True):
            # a cell without the value (no encounter, no Oracle to compare with) is left out
            shown = {cell: kept for cell, rs in lines.items()
                     if (kept := [r for r in rs if r[value] is not None])}
            top = max([1.0, *(r[value] for rs in shown.values() for r in rs)])
            curves = [np.array([[(r["jitter"] + dodge[cell]) / span, r[value] / top]
                                for r in rs]) for cell, rs in shown.items()]
            covers = [int(c.max()) for c in _covers(curves, 0.02)]
            for (cell, rs), widen in zip(shown.items(), covers, strict=True):
                jit = np.array([r["jitter"] for r in rs]) + dodge[cell]
                y = np.array([r[value] for r in rs])
                err = np.abs(np.array([r[ci] for r in rs]).T - y) if ci else None
                marker = _point(styles[cell], widen)
                ax.errorbar(jit, y, yerr=err, capsize=3, elinewidth=1.0, marker=marker["marker"],
                            ms=marker["ms"], mec="black", mew=0.6,
                            **_line(styles[cell], widen))
            if not shown:
                ax.text(0.5, 0.5, missing, ha="center", va="center", transform=ax.transAxes,
                        color="0.4")
            ax.set_ylim(-0.05 * top, 1.05 * top)
            ax.set_xticks(sorted({r["jitter"] for r in rows}))  # the levels, not the dodges
            ax.set_xlabel("jitter level")
            ax.set_ylabel(what)
            ax.set_title(f"{sc}: {what}" + (" (95% Wilson CI)" if ci else ""),
                         fontsize="medium")
            ax.grid(alpha=0.3)
    _legend(fig, styles, "equal results nest:\nthe first listed widest", lines=True)
    _save(fig, path)


def _false_alarms_vs_collisions(path: Path, rows: Sequence[dict[str, Any]],
                                scenarios: list[str], styles: dict[str, dict[str, Any]]
                                ) -> None:
    """One panel per scenario and jitter level: each cell's false alarms per minute and
    collision rate, or for a roam task collisions per minute (over a fixed time nearly
    every episode touches something: its collision rate is about 1 for every cell); equal
    points nest (the first listed largest)."""
    jitters = sorted({r["jitter"] for r in rows})
    fig = figure(figsize=(max(3.6 * len(jitters), 4.6) + 3.2, 3.3 * len(scenarios)))
    axes = fig.subplots(len(scenarios), len(jitters), squeeze=False, sharex=True,
                        sharey="row")
    span = max(1.0, max(r["false_alarms_per_min"] for r in rows))
    order = list(styles)
    for i, sc in enumerate(scenarios):
        own = [r for r in rows if r["scenario"] == sc]
        value, what = (("collision_rate", "collision rate") if _is_goal(own[0])
                       else ("collisions_per_min", "collisions per minute"))
        top = max(1.0, *(r[value] for r in own))
        for ax, j in zip(axes[i], jitters, strict=True):
            cells = sorted((r for r in own if r["jitter"] == j),
                           key=lambda r: order.index(r["cell"]))
            points = [np.array([[r["false_alarms_per_min"] / span, r[value] / top]])
                      for r in cells]
            for r, widen in zip(cells, _covers(points, 0.03), strict=True):
                ax.plot(r["false_alarms_per_min"], r[value],
                        **_point(styles[r["cell"]], int(widen[0])))
            ax.set_title(f"{sc}, jitter {j:g}", fontsize="medium")
            ax.grid(alpha=0.3)
            ax.set_xlabel("false alarms per minute")
            ax.set_ylabel(what)
        axes[i, 0].set_ylim(-0.08 * top, 1.08 * top)
    axes[0, 0].set_xlim(-0.06 * span, 1.06 * span)
    # from the left: centred on the figure, a narrow one's title ran under the legend
    fig.suptitle("The cost of avoiding (lower left is better)", fontsize="medium", x=0.02,
                 ha="left")
    _legend(fig, styles, "equal points nest:\nthe first listed largest", lines=False)
    _save(fig, path)


def draw_world(ax, view: dict[str, Any]) -> None:
    """Draw an episode's world from above on matplotlib axes `ax`: the terrain's heights
    (grey, where `view` has "terrain" and its "extent") and the obstacles, arena walls
    among them (brown; each a "polygon" of (x, y) corners or a "circle" (x, y, radius)).

    `view` is a top view as `lgmd_sim.world.core.JitterWorld.top_view` gives it (the
    closed-loop records' and the avoidance demo's); the axes keep their limits and aspect.
    """
    from matplotlib.patches import Circle, Polygon

    if "terrain" in view:
        ax.imshow(np.array(view["terrain"]), origin="lower", extent=view["extent"],
                  cmap="Greys", alpha=0.45, zorder=0)
    for ob in view["obstacles"]:
        patch = (Polygon(ob["polygon"]) if "polygon" in ob
                 else Circle(ob["circle"][:2], ob["circle"][2]))
        patch.set(facecolor="#8C564B", edgecolor="black", lw=0.6, zorder=1)
        ax.add_patch(patch)


def map_bounds(group: Sequence[dict[str, Any]]) -> np.ndarray:
    """The box around one map's drawing, [[x0, y0], [x1, y1]] (m), with a margin: every
    record's path (its ``top_view["path"]``) and the first's obstacles and goal (records
    of one scenario, jitter level and seed share the world)."""
    view = group[0]["top_view"]
    points = [np.array(r["top_view"]["path"]).reshape(-1, 2) for r in group]
    for ob in view["obstacles"]:
        if "polygon" in ob:
            points.append(np.array(ob["polygon"]))
        else:
            x, y, radius = ob["circle"]
            points.append(np.array([[x - radius, y - radius], [x + radius, y + radius]]))
    if view["goal"]:
        points.append(np.array([view["goal"]]))
    xy = np.concatenate(points)
    return np.array([xy.min(axis=0) - _PAD, xy.max(axis=0) + _PAD])


def _trajectories(path: Path, examples: Sequence[dict[str, Any]], scenarios: list[str],
                  styles: dict[str, dict[str, Any]]) -> None:
    """Top views of the seeds with one, a row per scenario and seed and a column per
    jitter level: terrain, obstacles, each controller's path; the axes span what is drawn
    (one extent per scenario, shared by its panels)."""
    panels = sorted({(r["scenario"], r["seed"], r["jitter"]) for r in examples})
    jitters = sorted({j for *_, j in panels})
    order = list(styles)
    groups = {p: sorted((r for r in examples if (r["scenario"], r["seed"], r["jitter"]) == p),
                        key=lambda r: order.index(r["cell"])) for p in panels}
    extents = {}
    for sc in scenarios:
        boxes = [map_bounds(g) for (s, _, _), g in groups.items() if s == sc]
        if boxes:
            extents[sc] = np.array([np.min([b[0] for b in boxes], axis=0),
                                    np.max([b[1] for b in boxes], axis=0)])
    rows_of = sorted({(sc, seed) for sc, seed, _ in panels}, key=lambda r: (
        list(extents).index(r[0]), r[1]))
    width = 4.6  # inches per panel; its height follows the extent (equal axes)
    heights = [float(np.clip(width * np.divide(*np.diff(extents[sc], axis=0)[0][::-1]),
                             1.6, 6.0)) for sc, _ in rows_of]
    fig = figure(figsize=(width * len(jitters) + 3.2, sum(heights) + 0.9 * len(heights)))
    axes = fig.subplots(len(rows_of), len(jitters), squeeze=False,
                        height_ratios=heights)
    for ax in axes.ravel():
        ax.axis("off")  # panels without a top view stay empty
    for (sc, seed, j), group in groups.items():
        ax = axes[rows_of.index((sc, seed)), jitters.index(j)]
        ax.axis("on")
        view = group[0]["top_view"]
        draw_world(ax, view)
        paths = [np.array(r["top_view"]["path"]).reshape(-1, 2) for r in group]
        for r, xy, cover in zip(group, paths, _covers(paths, 0.05), strict=True):
            # wider only where later paths run over it: nested stripes there
            for level in range(cover.max(), -1, -1):
                ax.plot(*np.where((cover >= level)[:, None], xy, np.nan).T,
                        **_line(styles[r["cell"]], level))
        # each path's end: the cell's marker; a black cross at its first collision (the end
        # where a collision ends the episode; a roam task's path goes on)
        ends = [xy[-1][None] for xy in paths]
        for r, xy, end, cover in zip(group, paths, ends, _covers(ends, 0.15), strict=True):
            ax.plot(*end[0], **_point(styles[r["cell"]], int(cover[0])))
            hit = r["top_view"]["collision_frame"]
            if hit is not None:
                ax.plot(*xy[hit], marker="x", ms=6, mew=1.6, color="black", ls="none",
                        zorder=4)
        if view["goal"]:
            ax.plot(*view["goal"], marker="*", ms=16, color="gold", mec="black", ls="none",
                    zorder=4)
        (x0, y0), (x1, y1) = extents[sc]
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_title(f"{sc}, jitter {j:g}, seed {seed}", fontsize="small")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    _legend(fig, styles, "marker: the path's end;\nx: its first collision;\nequal paths nest as "
            "stripes,\nthe first listed widest", lines=True)
    _save(fig, path)


def _encounter_map(path: Path, examples: Sequence[dict[str, Any]],
                   styles: dict[str, dict[str, Any]]) -> None:
    """A roam scenario at one jitter level from above, a panel per cell: the world, the
    example episode's path from its start, and each encounter where it began, avoided or
    not."""
    from matplotlib import patheffects
    from matplotlib.lines import Line2D

    order = list(styles)
    group = sorted(examples, key=lambda r: order.index(r["cell"]))
    (x0, y0), (x1, y1) = map_bounds(group)
    cols = min(3, len(group))
    rows_n = -(-len(group) // cols)
    width = 4.4  # inches per panel; its height follows the extent (equal axes)
    height = float(np.clip(width * (y1 - y0) / (x1 - x0), 1.6, 6.0))
    fig = figure(figsize=(width * cols + 0.4, (height + 0.7) * rows_n + 0.9))
    axes = fig.subplots(rows_n, cols, squeeze=False).ravel()
    halo = [patheffects.withStroke(linewidth=4, foreground="white")]
    for ax, r in zip(axes, group, strict=False):
        view = r["top_view"]
        draw_world(ax, view)
        xy = np.array(view["path"]).reshape(-1, 2)
        ax.plot(*xy.T, **_line(styles[r["cell"]], 0))
        ax.plot(*xy[0], **{**_point(styles[r["cell"]], 0), "ms": 6})
        marks = view.get("encounters", [])
        for x, y, avoided in marks:
            ax.plot(x, y, **(_AVOIDED if avoided else _FAILED), path_effects=halo)
        kept = sum(m[2] for m in marks)
        ax.set_title(f"{r['cell']}: {kept} of {len(marks)} avoided", fontsize="small")
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    for ax in axes[len(group):]:
        ax.axis("off")
    handles = [Line2D([], [], label="encounter avoided", **_AVOIDED),
               Line2D([], [], label="encounter with a collision", **_FAILED),
               Line2D([], [], label="start", marker="o", ms=6, color="0.5", mec="black",
                      ls="none")]
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize="small")
    first = group[0]
    fig.suptitle(f"{first['scenario']}, jitter {first['jitter']:g}, seed {first['seed']}: "
                 "where each encounter began", fontsize="medium")
    _save(fig, path)


def open_loop(folder: Path, rows: Sequence[dict[str, Any]],
              records: Sequence[dict[str, Any]]) -> list[str]:
    """The open-loop figures: detection curves per scenario and jitter (clean clips), and
    MpSI and SI against the noise level; returns the file names written."""
    made = [_detection_curves(folder / "detection_curves.png", records)]
    if any(r["noise"] for r in rows):
        made.append(_noise(folder / "noise.png", rows))
    return made


def _detection_curves(path: Path, records: Sequence[dict[str, Any]]) -> str:
    groups: dict[tuple, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for rec in records:
        for row in rec["rows"]:
            if not row["noise"]:
                pooled = groups[(rec["scenario"], rec["jitter"])][row["detector"]]
                pooled.append((row["potential"], rec["near"]))
    panels = sorted(groups)
    cols = min(3, len(panels))
    rows_n = -(-len(panels) // cols)
    fig = figure(figsize=(4.6 * cols + 1.5, 4.2 * rows_n))
    axes = fig.subplots(rows_n, cols, squeeze=False).ravel()
    for ax, key in zip(axes, panels, strict=False):
        for det, pairs in sorted(groups[key].items()):
            scores = np.concatenate([p for p, _ in pairs])
            near = np.concatenate([n for _, n in pairs]).astype(bool)
            auc = metrics.roc_auc(scores, near)
            if auc is None:  # no dangerous frame (a near miss) or no safe one
                continue
            fpr, tpr, _ = metrics.roc_curve(scores, near)
            style = {k: v for k, v in model_style(det).items() if k != "alpha"}
            ax.plot(fpr, tpr, label=f"{det} (AUC {auc:.2f})", **style)
        ax.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls=":")
        ax.set_title(f"{key[0]}, jitter {key[1]:g}", fontsize="medium")
        ax.set_xlabel("false positive rate (frames)")
        ax.set_ylabel("true positive rate")
        ax.set_aspect("equal")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower right", fontsize="x-small")
        else:
            ax.text(0.5, 0.5, "no frame within the horizon", ha="center", transform=ax.transAxes)
    for ax in axes[len(panels):]:
        ax.axis("off")
    fig.suptitle("Per-frame potential as a detector of an obstacle within the time-to-"
                 "collision horizon (clean clips)")
    _save(fig, path)
    return path.name


def _noise(path: Path, rows: Sequence[dict[str, Any]]) -> str:
    """MpSI and SI against the noise level per model (the paper's Figs. 7-8)."""
    noisy = [r for r in rows if r["noise"]]
    scenarios = sorted({r["scenario"] for r in noisy})
    kinds = sorted({r["noise"].split(":")[0] for r in noisy})
    fig = figure(figsize=(11, 3.4 * len(scenarios) * len(kinds)))
    axes = fig.subplots(len(scenarios) * len(kinds), 2, squeeze=False)
    for i, (sc, kind) in enumerate((s, k) for s in scenarios for k in kinds):
        for det in sorted({r["detector"] for r in noisy}):
            clean = [r for r in rows if r["scenario"] == sc and r["detector"] == det
                     and not r["noise"] and r["jitter"] == 0]
            pts = sorted(((float(r["noise"].split(":")[1]), r) for r in noisy
                          if r["scenario"] == sc and r["detector"] == det
                          and r["noise"].startswith(kind + ":")), key=lambda x: x[0])
            pts = [(0.0, clean[0])] * bool(clean) + pts
            style = {k: v for k, v in model_style(det).items() if k != "alpha"}
            for ax, what in zip(axes[i], ("mpsi", "si"), strict=True):
                ax.plot([x for x, _ in pts], [r[what] for _, r in pts], marker="o", ms=4,
                        label=det, **style)
        for ax, what in zip(axes[i], ("MpSI", "SI"), strict=True):
            ax.set_title(f"{sc}: {what} with {kind} noise (mean over clips)",
                         fontsize="medium")
            ax.set_xlabel("variance" if kind == "gaussian" else "density")
            ax.set_ylabel(what)
            ax.grid(alpha=0.3)
        axes[i, 1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    _save(fig, path)
    return path.name
