"""Figures of the model benchmark (the styles are lgmd_sim.plots')."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim import metrics
from lgmd_sim.fileio import write_files
from lgmd_sim.plots import figure, model_style

__all__ = ["CLOSED_LOOP", "closed_loop", "open_loop"]

#: The closed-loop benchmark's figures.
CLOSED_LOOP = ("collisions_vs_jitter.png", "false_alarms_vs_collisions.png",
               "trajectories.png")
_CONTROLLER_STYLES = {
    "oracle": {"color": "black", "ls": "-", "lw": 1.6, "marker": "s"},
    "straight": {"color": "0.55", "ls": ":", "lw": 1.6, "marker": "x"},
}


#: Colours of trained policies' cells, by the order of their tags in the run.
_POLICY_COLOURS = ["#56B4E9", "#7F3C8D", "#17BECF", "#8C564B", "#BCBD22", "#E15759"]


def _style(row: dict[str, Any], tags: Sequence[str] = ()) -> dict[str, Any]:
    if row.get("tag") in tags:  # a trained policy: a colour of its own, dash-dotted
        colour = _POLICY_COLOURS[list(tags).index(row["tag"]) % len(_POLICY_COLOURS)]
        return {"color": colour, "ls": "-.", "lw": 1.8, "marker": "^"}
    if row["model"] is None:
        return dict(_CONTROLLER_STYLES.get(row["controller"], {"color": "0.3", "marker": "^"}))
    return {**model_style(f"{row['model']}/{row['preset']}"), "marker": "o"}


def _save(fig, path: Path) -> None:
    write_files({path: lambda tmp: fig.savefig(tmp, format="png", dpi=110)})


def closed_loop(folder: Path, rows: Sequence[dict[str, Any]],
                examples: Sequence[dict[str, Any]]) -> None:
    """The closed-loop figures (`CLOSED_LOOP`) from the summary rows and the records that
    carry a top view (one seed per cell)."""
    scenarios = sorted({r["scenario"] for r in rows})
    tags = sorted({r["tag"] for r in rows if r.get("tag")})
    _rates_vs_jitter(folder / CLOSED_LOOP[0], rows, scenarios, tags)
    _false_alarms_vs_collisions(folder / CLOSED_LOOP[1], rows, scenarios, tags)
    _trajectories(folder / CLOSED_LOOP[2], examples, scenarios, tags)


def _rates_vs_jitter(path: Path, rows: Sequence[dict[str, Any]], scenarios: list[str],
                     tags: Sequence[str]) -> None:
    fig = figure(figsize=(11, 3.6 * len(scenarios)))
    axes = fig.subplots(len(scenarios), 2, squeeze=False)
    for (ax_col, ax_suc), sc in zip(axes, scenarios, strict=True):
        lines: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for r in rows:
            if r["scenario"] == sc:
                lines[r["cell"]].append(r)
        for cell, rs in sorted(lines.items()):
            rs.sort(key=lambda r: r["jitter"])
            jit = np.array([r["jitter"] for r in rs])
            style = _style(rs[0], tags)
            for ax, rate, ci in ((ax_col, "collision_rate", "collision_ci"),
                                 (ax_suc, "success_rate", "success_ci")):
                y = np.array([r[rate] for r in rs])
                err = np.abs(np.array([r[ci] for r in rs]).T - y)
                ax.errorbar(jit, y, yerr=err, capsize=3, label=cell, **style)
        for ax, what in ((ax_col, "collision rate"), (ax_suc, "success rate")):
            ax.set_ylim(-0.03, 1.03)
            ax.set_xlabel("jitter level")
            ax.set_ylabel(what)
            ax.set_title(f"{sc}: {what} (95% Wilson CI)", fontsize="medium")
            ax.grid(alpha=0.3)
        ax_suc.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    _save(fig, path)


def _false_alarms_vs_collisions(path: Path, rows: Sequence[dict[str, Any]],
                                scenarios: list[str], tags: Sequence[str]) -> None:
    fig = figure(figsize=(8.5, 4.2 * len(scenarios)))
    axes = fig.subplots(len(scenarios), 1, squeeze=False)[:, 0]
    markers = ["o", "s", "^", "D", "v", "P"]
    for ax, sc in zip(axes, scenarios, strict=True):
        jitters = sorted({r["jitter"] for r in rows if r["scenario"] == sc})
        for r in rows:
            if r["scenario"] != sc:
                continue
            style = _style(r, tags)
            ax.plot(r["false_alarms_per_min"], r["collision_rate"], ls="none", ms=8,
                    marker=markers[jitters.index(r["jitter"]) % len(markers)],
                    color=style["color"], mec="black", mew=0.5)
        for cell in sorted({r["cell"] for r in rows if r["scenario"] == sc}):
            r = next(x for x in rows if x["cell"] == cell)
            ax.plot([], [], ls="none", marker="o", color=_style(r, tags)["color"], label=cell)
        for k, j in enumerate(jitters):
            ax.plot([], [], ls="none", marker=markers[k % len(markers)], color="white",
                    mec="black", label=f"jitter {j:g}")
        ax.set_xlabel("false alarms per minute")
        ax.set_ylabel("collision rate")
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
        ax.set_title(f"{sc}: the cost of avoiding (lower left is better)", fontsize="medium")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    _save(fig, path)


def _trajectories(path: Path, examples: Sequence[dict[str, Any]], scenarios: list[str],
                  tags: Sequence[str]) -> None:
    """Top views of one seed per jitter level: terrain, obstacles, each controller's path."""
    from matplotlib.patches import Circle, Polygon

    panels = sorted({(r["scenario"], r["jitter"]) for r in examples})
    if not panels:
        return
    cols = len({j for _, j in panels})
    fig = figure(figsize=(5.2 * cols, 4.4 * len(scenarios)))
    axes = fig.subplots(len(scenarios), cols, squeeze=False)
    jitters = sorted({j for _, j in panels})
    for (sc, j) in panels:
        ax = axes[scenarios.index(sc), jitters.index(j)]
        group = [r for r in examples if r["scenario"] == sc and r["jitter"] == j]
        view = group[0]["top_view"]
        if "terrain" in view:
            ax.imshow(np.array(view["terrain"]), origin="lower", extent=view["extent"],
                      cmap="Greys", alpha=0.55)
        for ob in view["obstacles"]:
            patch = (Polygon(ob["polygon"]) if "polygon" in ob
                     else Circle(ob["circle"][:2], ob["circle"][2]))
            patch.set(facecolor="#8C564B", edgecolor="black", lw=0.6)
            ax.add_patch(patch)
        for r in sorted(group, key=lambda r: (r["model"] is None, r["controller"])):
            xy = np.array(r["top_view"]["path"])
            style = {k: v for k, v in _style(r, tags).items() if k != "marker"}
            label = r["controller"] + (f": {r['model']}/{r['preset']}" if r["model"] else
                                       f": {r['tag']}" if r.get("tag") else "")
            ax.plot(xy[:, 0], xy[:, 1], label=label, **style)
            hit = r["top_view"]["collision_frame"]
            if hit is not None:
                ax.plot(*xy[hit], marker="X", ms=10, color=style["color"], mec="black")
        if view["goal"]:
            ax.plot(*view["goal"], marker="*", ms=16, color="gold", mec="black", ls="none")
        ax.set_aspect("equal")
        ax.set_title(f"{sc}, jitter {j:g}, seed {group[0]['seed']} (X: collision)",
                     fontsize="small")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    axes[0, -1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
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
