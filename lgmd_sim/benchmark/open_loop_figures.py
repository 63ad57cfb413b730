"""Figures of the open-loop benchmark (`lgmd_sim.benchmark.open_loop`): the detection
curves per scenario and jitter level, and MpSI and SI against the noise level (the styles
are lgmd_sim.core.plots').
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.benchmark.drawing import save_figure
from lgmd_sim.core.plots import figure, model_style
from lgmd_sim.signals import metrics

__all__ = ["open_loop"]


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
    save_figure(fig, path)
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
    save_figure(fig, path)
    return path.name
