"""A detection drawn: every model's membrane potential over a clip with its first alarm,
the threshold and the labelled collision (`draw_potentials`), and a model's legend entry
(`alarm_label`), in the figure conventions of `lgmd_sim.core.plots`."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim import metrics
from lgmd_sim.core.plots import COLLISION, THRESHOLD, model_style
from lgmd_sim.detect.results import Detection

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["alarm_label", "draw_potentials", "draw_thresholds"]

#: The dashes of a threshold line (dash, dot, dot: no model's own line style, so that it
#: is not taken for a potential in the same colour), and their period (points).
_THRESHOLD_DASHES = (6.0, 2.0, 1.0, 2.0, 1.0, 2.0)
_PERIOD = sum(_THRESHOLD_DASHES)


def alarm_label(name: str, first_alarm: int | None, event: metrics.EventResult | None) -> str:
    """A model's legend entry: its first alarm and, against a labelled collision, the
    outcome and lead time."""
    alarm = "no alarm" if first_alarm is None else f"alarm at {first_alarm}"
    if event is None:
        return f"{name}: {alarm}"
    if event.lead_s is None:
        return f"{name}: {alarm}, {event.outcome}"
    when = "early" if event.outcome == "miss" and event.lead_frames > 0 else (
        "late" if event.outcome == "miss" else "at the collision frame"
        if event.lead_frames == 0 else "")
    return (f"{name}: {alarm}, {event.outcome}{' (' + when + ')' if when else ''}, "
            f"lead {event.lead_s:.2f} s")


def draw_thresholds(ax: Axes, thresholds: dict[str, float],
                    style_of: Callable[[str], dict[str, Any]] = model_style,
                    values: bool = True) -> None:
    """Each model's alarm threshold (`thresholds`, by the model's name) tied to its model: a
    dash-dot-dot line in the model's colour, labelled "threshold of MODEL" for the legend, and
    (`values`; not where a twin axis has the right edge) its value in that colour beside
    the axes' right edge. Models whose thresholds coincide
    share a label ("every model" where they all do); in different colours, their dashes
    alternate so that each colour shows."""
    from matplotlib.colors import to_rgb

    shared: dict[float, list[str]] = {}
    for name, threshold in thresholds.items():
        shared.setdefault(threshold, []).append(name)
    marks = []
    for threshold, names in sorted(shared.items()):
        who = (names[0] if len(names) == 1 else "every model" if len(shared) == 1
               else ", ".join(names))
        colours = list(dict.fromkeys(to_rgb(style_of(n)["color"]) for n in names))
        # each colour's dashes, then a gap as long as the others' (their turns)
        dashes = (*_THRESHOLD_DASHES[:-1], _THRESHOLD_DASHES[-1] + _PERIOD * (len(colours) - 1))
        for k, colour in enumerate(colours):
            ax.axhline(threshold, **{**THRESHOLD, "color": colour, "lw": 1.1,
                                     "ls": (k * _PERIOD, dashes)},
                       label=f"threshold of {who}: {threshold:g}" if k == 0 else None)
        marks.append((threshold, colours[0] if len(colours) == 1 else THRESHOLD["color"]))
    # the values beside the right edge, outside the data, read on the axes' limits as
    # they stand (set them first); those close together pushed apart (a share of the
    # axes' height) so that none covers another
    low, high = ax.get_ylim()
    placed = -1.0
    for threshold, colour in marks if values else ():
        placed = max((threshold - low) / (high - low), placed + 0.045)
        ax.annotate(f"{threshold:g}", xy=(1.0, threshold), xycoords=ax.get_yaxis_transform(),
                    xytext=(1.01, placed), textcoords="axes fraction", va="center",
                    fontsize="x-small", color=colour, annotation_clip=False)


def draw_potentials(ax: Axes, d: Detection, legend: bool = True,
                    style_of: Callable[[str], dict[str, Any]] = model_style) -> None:
    """Every model's membrane potential over the frames of a clip, its first alarm
    marked, the threshold, and the labelled collision frame; each model's line in
    `style_of` its name."""
    frames = np.arange(d.frames)
    for name, tr in d.models.items():
        style = style_of(name)
        ax.plot(frames, tr.potential, label=alarm_label(name, tr.first_alarm, tr.event),
                **style)
        if tr.first_alarm is not None:
            ax.plot(tr.first_alarm, tr.potential[tr.first_alarm], marker="v", ms=9,
                    color=style["color"], mec="black", mew=0.8, ls="none",
                    zorder=style.get("zorder", 4) + 1)
    ax.set_ylim(0.45, 1.02)
    draw_thresholds(ax, {name: tr.threshold for name, tr in d.models.items()}, style_of)
    rules: dict[metrics.AlarmRule, list[str]] = {}
    for name, tr in d.models.items():
        rules.setdefault(tr.alarm_rule, []).append(name)
    for rule, names in rules.items():  # where it is not the paper's, every frame above
        if rule != metrics.PAPER_ALARM:
            whose = "" if len(rules) == 1 else f"{', '.join(names)}: "
            ax.plot([], [], ls="none", label=f"{whose}an alarm is {rule} the threshold")
    ax.plot([], [], marker="v", color="white", mec="black", ls="none", label="first alarm")
    if d.collision_frame is not None:
        ax.axvline(d.collision_frame, **COLLISION)
        ax.text(d.collision_frame - 0.01 * d.frames, 0.03,
                f"collision (frame {d.collision_frame})", transform=ax.get_xaxis_transform(),
                ha="right", va="bottom", fontsize="small",
                bbox={"fc": "white", "ec": "none", "pad": 1})
    ax.set_ylabel("membrane potential")
    ax.set_xlabel("frame")
    if legend:
        title = "model: first alarm" + (", outcome" if d.collision_frame is not None else "")
        # clear of the thresholds' values beside the right edge
        ax.legend(loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize="small", title=title,
                  title_fontsize="small")
