"""What a calibration shows of its choice: the summary table (summary.md) and the
figure (calibration.png) of each detector's chosen candidate, search and held-out.

Apart from the job (`lgmd_sim.calibration.run`) because a figure is also drawn again,
from a finished run or a presets file (`lgmd_sim.calibration.redraw`), and the pages of
docs/experiments print the table, without running a calibration.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim.calibration.objective import WALKER, Objective

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["calibration_figure", "summary_markdown"]


def _sets(chosen: Sequence[dict[str, Any]]) -> list[str]:
    """The clip sets the chosen candidates were scored on, in order: search, held-out,
    then any transfer set (`choose` keeps them in the order of its clip sets)."""
    return [k for k, v in chosen[0].items() if isinstance(v, dict) and "objective" in v]


def _set_label(name: str) -> str:
    return {"heldout": "held-out"}.get(name, name)


def summary_markdown(chosen: Sequence[dict[str, Any]], objective: Objective = WALKER) -> str:
    """The chosen candidates, search and held-out (and transfer, where there is one), as
    a Markdown table: the objective and each of its parts ("-" for a part the clips lack,
    which the objective leaves out)."""
    sets = _sets(chosen)
    lines = [f"| detector | threshold | objective {' / '.join(map(_set_label, sets))} | "
             + " | ".join(objective.parts.values()) + " |",
             "|---|---:|---:|" + "---:|" * len(objective.parts)]
    for c in chosen:
        cells = [" / ".join(f"{c[n][k]:.2f}" for n in sets) if k in c["search"] else "-"
                 for k in objective.parts]
        score = " / ".join(f"{c[n]['objective']:.3f}" for n in sets)
        lines.append(f"| {c['detector']} | {c['threshold']:.3f} | {score} | "
                     f"{' | '.join(cells)} |")
    return "\n".join(lines) + "\n"


#: Inches: what each detector's pair of bars takes in a panel, and the least a panel is
#: wide, so that its title and the legend fit with a single detector.
_PER_DETECTOR, _MIN_PANEL = 0.6, 3.4
#: The y axis of calibration.png: the objective and each part, a share of clips (frames
#: for the robot's balanced accuracy) that went as the panel's title says.
SCORE_LABEL = "score (0 to 1, 1 best)"


def calibration_figure(chosen: Sequence[dict[str, Any]], objective: Objective = WALKER
                       ) -> Figure:
    """calibration.png: for the objective and each of its parts, each chosen detector's
    score on the search and the held-out seeds (and the transfer set, where there is
    one)."""
    from matplotlib.patches import Patch

    from lgmd_sim.core.plots import figure, model_style

    names = [c["detector"] for c in chosen]
    panels = ("objective", *objective.parts)
    cols = -(-len(panels) // 2)  # two rows
    fig = figure(figsize=(cols * max(_MIN_PANEL, _PER_DETECTOR * len(names)) + 0.8, 9.0))
    axes = fig.subplots(2, cols, sharey=True).ravel()
    for ax in axes[len(panels):]:
        ax.axis("off")
    x = np.arange(len(names))
    colours = [model_style(n.split("-")[0])["color"] for n in names]
    bar = {"edgecolor": "black", "lw": 0.5}
    sets = _sets(chosen)
    alphas = dict(zip(sets, (1.0, 0.45, 0.2), strict=False))
    width = 0.76 / len(sets)
    for ax, what in zip(axes, panels, strict=False):
        for k, set_name in enumerate(sets):
            # a part the clips lack has no bar
            bars = ax.bar(x + (k - (len(sets) - 1) / 2) * width,
                          [c[set_name].get(what, np.nan) for c in chosen],
                          width, color=colours, alpha=alphas[set_name], **bar)
            for b, n in zip(bars, names, strict=True):
                if "open-loop" in n:  # the feedback LGMD's control: its colour, hatched
                    b.set_hatch("//")
        ax.set_xticks(x, names, rotation=45, ha="right", fontsize="small")
        ax.set_xlim(-0.7, len(names) - 0.3)  # a lone detector's bars keep their width
        ax.set_title(objective.titles[what], fontsize="medium")
        ax.set_ylim(0, 1.02)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes[::cols]:  # the first of each row (the others share its y axis)
        ax.set_ylabel(SCORE_LABEL)
    # the key in grey: the bars' colours are the detectors', named below each pair
    handles = [Patch(facecolor="0.4", alpha=alphas[n], label=f"{_set_label(n)} seeds"
                     if n in ("search", "heldout") else f"{n}: held-out seeds in other looks",
                     **bar) for n in sets]
    if any("open-loop" in n for n in names):
        handles.append(Patch(facecolor="white", hatch="//",
                             label="the feedback LGMD's open-loop control", **bar))
    fig.legend(handles=handles, loc="outside upper center", ncols=len(handles),
               fontsize="small", title="bars in each detector's colour",
               title_fontsize="small")
    return fig
