"""Figure conventions shared by every plot: one style per model, the threshold and the
collision marks, and the legend line of a model's response to a clip.

Colours are the Okabe-Ito palette (distinguishable with colour-vision deficiencies); each
model also has its own line style and width, so curves that coincide stay visible (f_on
is a wide translucent band, f_off a dotted line on top of it). No model is black or grey:
black marks the collision, grey the threshold.
"""

from __future__ import annotations

from typing import Any

from lgmd_sim import metrics

__all__ = ["COLLISION", "THRESHOLD", "alarm_label", "model_style"]

_STYLES: dict[str, dict[str, Any]] = {
    "feedback": {"color": "#0072B2", "ls": "-", "lw": 2.2, "zorder": 5},
    "lgmd1": {"color": "#E69F00", "ls": (0, (5, 2)), "lw": 1.6, "zorder": 4},
    "lgmd2": {"color": "#009E73", "ls": (0, (7, 2, 1.5, 2)), "lw": 1.6, "zorder": 4},
    "f_on": {"color": "#CC79A7", "ls": "-", "lw": 4.5, "alpha": 0.45, "zorder": 3},
    "f_off": {"color": "#D55E00", "ls": (0, (1, 1.3)), "lw": 2.0, "zorder": 4},
}
_OTHERS = ["#56B4E9", "#F0E442", "#8C564B", "#17BECF"]
#: The labelled collision frame: a vertical black line.
COLLISION: dict[str, Any] = {"color": "black", "ls": "-", "lw": 1.2}
#: The alarm threshold: a horizontal grey dashed line.
THRESHOLD: dict[str, Any] = {"color": "0.45", "ls": "--", "lw": 1.0}


def model_style(name: str) -> dict[str, Any]:
    """Line style of a model; variants ("feedback/calibrated") take their base's colour."""
    base = name.split("/")[0].split("+")[0]
    if base in _STYLES:
        return dict(_STYLES[base])
    return {"color": _OTHERS[sum(map(ord, name)) % len(_OTHERS)], "ls": "-", "lw": 1.6}


def alarm_label(name: str, first_alarm: int | None, event: metrics.EventResult | None) -> str:
    """A model's legend entry: its first alarm and, against a labelled collision, the
    outcome and lead time."""
    alarm = "no alarm" if first_alarm is None else f"alarm at {first_alarm}"
    if event is None:
        return f"{name}: {alarm}"
    if event.lead_s is None:
        return f"{name}: {alarm}, {event.outcome}"
    when = "early" if event.outcome == "miss" and event.lead_frames > 0 else (
        "late" if event.outcome == "miss" else "")
    return (f"{name}: {alarm}, {event.outcome}{' (' + when + ')' if when else ''}, "
            f"lead {event.lead_s:.2f} s")
