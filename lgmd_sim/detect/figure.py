"""A detection drawn: every model's membrane potential over a clip with its first alarm,
the threshold and the labelled collision (`draw_potentials`), and a model's legend entry
(`alarm_label`), in the figure conventions of `lgmd_sim.plots`."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim import metrics
from lgmd_sim.detect.results import Detection
from lgmd_sim.plots import COLLISION, THRESHOLD, model_style

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["alarm_label", "draw_potentials"]


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
    for threshold in sorted({tr.threshold for tr in d.models.values()}):
        ax.axhline(threshold, label=f"threshold {threshold:g}", **THRESHOLD)
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
    ax.set_ylim(0.45, 1.02)
    if legend:
        title = "model: first alarm" + (", outcome" if d.collision_frame is not None else "")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", title=title,
                  title_fontsize="small")
