"""A detection drawn: every model's membrane potential over a clip with its first alarm,
the threshold and the labelled collision (`draw_potentials`), one panel per model
(`draw_by_model`, `detection_figure`: what `lgmd-sim detect` writes), and a model's legend
entry (`alarm_label`), in the figure conventions of `lgmd_sim.core.plots`."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lgmd_sim.core.plots import COLLISION, THRESHOLD, model_style
from lgmd_sim.detect.results import Detection
from lgmd_sim.detect.specs import model_of
from lgmd_sim.signals import metrics

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["alarm_label", "by_model", "detection_figure", "draw_by_model", "draw_potentials",
           "draw_thresholds"]

#: Inches: the height of a model's panel, and of the SSIM's.
PANEL_HEIGHT, SSIM_HEIGHT = 1.9, 1.5

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
                    style_of: Callable[[str], dict[str, Any]] = model_style,
                    collision_text: bool = True) -> None:
    """Every model's membrane potential over the frames of a clip, its first alarm
    marked, the threshold, and the labelled collision frame (named beside its line, or
    without `collision_text` in the legend); each model's line in `style_of` its name."""
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
    if d.collision_frame is not None and not collision_text:
        ax.axvline(d.collision_frame, **COLLISION,
                   label=f"collision (frame {d.collision_frame})")
    elif d.collision_frame is not None:
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


def by_model(d: Detection) -> dict[str, Detection]:
    """`d` split by model (`model_of`), in the order the models first come: per model,
    the detection of its detectors alone (a model at several presets stays together)."""
    groups: dict[str, dict[str, Any]] = {}
    for name, trace in d.models.items():
        groups.setdefault(model_of(name), {})[name] = trace
    return {m: dataclasses.replace(d, models=traces) for m, traces in groups.items()}


def draw_by_model(axes: Sequence[Axes], d: Detection) -> None:
    """One panel per model (`by_model`; `axes` one per model, top to bottom): its
    potentials with their first alarms, each threshold in its detector's colour, the
    labelled collision; its legend beside it, off the data (the first's with a title)."""
    panels = by_model(d)
    if len(axes) != len(panels):
        raise ValueError(f"{len(panels)} models ({', '.join(panels)}) need as many axes, "
                         f"not {len(axes)}")
    for k, (ax, (model, sub)) in enumerate(zip(axes, panels.items(), strict=True)):
        # the collision named in the legend: a small panel has no room clear of the data
        draw_potentials(ax, sub, legend=False, collision_text=False)
        ax.set_title(model, fontsize="medium", loc="left")
        if k < len(axes) - 1:
            ax.set_xlabel("")  # shared with the panel below
        title = (None if k else "model: first alarm"
                 + (", outcome" if d.collision_frame is not None else ""))
        # clear of the thresholds' values beside the right edge
        ax.legend(loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize="x-small",
                  title=title, title_fontsize="x-small")


def detection_figure(d: Detection, title: str | None = None, ssim: bool = True,
                     width: float = 10.0) -> Figure:
    """`lgmd-sim detect`'s figure, `width` inches wide: one panel per model
    (`draw_by_model`), and with `ssim` the SSIM of consecutive frames below them; `title`
    over it all (None: the clip's file name)."""
    from lgmd_sim.core.plots import figure

    n = len(by_model(d))
    heights = [PANEL_HEIGHT] * n + ([SSIM_HEIGHT] if ssim else [])
    fig = figure(figsize=(width, sum(heights) + 0.7))
    axes = np.atleast_1d(fig.subplots(len(heights), 1, sharex=True, height_ratios=heights))
    draw_by_model(list(axes[:n]), d)
    fig.suptitle(Path(d.video).name if title is None else title)
    if ssim:
        axes[n - 1].set_xlabel("")
        bottom = axes[n]
        if d.collision_frame is not None:
            bottom.axvline(d.collision_frame, **COLLISION)
        bottom.plot(np.arange(1, d.frames), d.ssim[1:], color="0.35", lw=1.2)
        bottom.set_ylabel("SSIM")
        bottom.set_xlabel("frame")
        bottom.set_title(f"SSIM of consecutive frames (ISI {d.isi:.4f})", fontsize="medium",
                         loc="left")
        bottom.set_ylim(min(0.0, float(np.min(d.ssim[1:], initial=1.0))), 1.02)
    return fig
