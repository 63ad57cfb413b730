"""Figure conventions shared by every plot: one style per model, the threshold and the
collision marks, and a figure drawn without any GUI backend.

Colours are the Okabe-Ito palette (distinguishable with colour-vision deficiencies); each
model also has its own line style and width, so curves that coincide stay visible (f_on
is a wide translucent band, f_off a dotted line on top of it). No model is black or grey:
black marks the collision, grey the threshold.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from matplotlib.colors import to_rgb

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["COLLISION", "MIN_CONTRAST", "THRESHOLD", "contrast", "figure", "model_style",
           "palette"]

_STYLES: dict[str, dict[str, Any]] = {
    "feedback": {"color": "#0072B2", "ls": "-", "lw": 2.2, "zorder": 5},
    "lgmd1": {"color": "#E69F00", "ls": (0, (5, 2)), "lw": 1.6, "zorder": 4},
    "lgmd2": {"color": "#009E73", "ls": (0, (7, 2, 1.5, 2)), "lw": 1.6, "zorder": 4},
    # translucent, yet reading on white (at 0.45 it did not: `MIN_CONTRAST`)
    "f_on": {"color": "#CC79A7", "ls": "-", "lw": 4.5, "alpha": 0.7, "zorder": 3},
    "f_off": {"color": "#D55E00", "ls": (0, (1, 1.3)), "lw": 2.0, "zorder": 4},
}
#: A detector of no built-in model (a plug-in): one of these, by its name. Each reads on
#: white (contrast at least `MIN_CONTRAST`; the Okabe-Ito yellow, 1.3, did not) and is
#: none of the models' hues.
_OTHERS = ["#56B4E9", "#7B3294", "#8C564B", "#17BECF"]
#: The least contrast ratio (WCAG's, 1 to 21) of a line's colour against the white
#: background: the Okabe-Ito orange and sky blue (2.2 to 2.3) read, its yellow does not.
MIN_CONTRAST = 2.0
#: The labelled collision frame: a vertical black line.
COLLISION: dict[str, Any] = {"color": "black", "ls": "-", "lw": 1.2}
#: The alarm threshold: a horizontal grey dashed line.
THRESHOLD: dict[str, Any] = {"color": "0.45", "ls": "--", "lw": 1.0}


def model_style(name: str) -> dict[str, Any]:
    """Line style of a detector ("model", "model/preset", with front ends): the model's
    own; a calibrated preset (calibrated, robot, video) in a darker shade of its colour, a
    front end (a camera stabilized by "image", "imu" or "pose") dotted, so that variants
    of one model differ."""
    head, *fronts = name.split("+")
    base, _, preset = head.partition("/")
    if base not in _STYLES:
        return {"color": _OTHERS[sum(map(ord, name)) % len(_OTHERS)], "ls": "-", "lw": 1.6}
    style = dict(_STYLES[base])
    if preset.startswith(("calibrated", "robot", "video")):
        style["color"] = tuple(0.6 * c for c in to_rgb(style["color"]))
    if fronts or any(f in preset.split("-") for f in ("image", "imu", "pose")):
        # dotted (f_off, dotted already: long dashes), unlike every model's own style
        style["ls"] = (0, (1, 1.2)) if base != "f_off" else (0, (8, 2))
        style["lw"] = style["lw"] + 0.6
    return style


def palette() -> list[tuple[float, float, float]]:
    """Every colour a detector's line shows on a white background: the models' own (a
    translucent one blended with the white), then those of the others (plug-ins)."""
    def shown(style: dict[str, Any]) -> tuple[float, float, float]:
        a = style.get("alpha", 1.0)
        r, g, b = (a * c + (1 - a) for c in to_rgb(style["color"]))
        return r, g, b

    return [shown(s) for s in _STYLES.values()] + [to_rgb(c) for c in _OTHERS]


def contrast(colour: Any, background: Any = "white") -> float:
    """WCAG 2 contrast ratio of two colours (1: none, 21: black on white)."""
    def luminance(c: Any) -> float:
        r, g, b = (v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4
                   for v in to_rgb(c))
        return 0.2126 * r + 0.7152 * g + 0.0722 * b

    low, high = sorted((luminance(colour), luminance(background)))
    return (high + 0.05) / (low + 0.05)


def figure(**kwargs: Any) -> Figure:
    """A matplotlib figure with a constrained layout, drawn without any GUI backend."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(layout="constrained", **kwargs)
    FigureCanvasAgg(fig)
    return fig
