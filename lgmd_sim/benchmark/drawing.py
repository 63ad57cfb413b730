"""Drawing the bench's figures share with each other and with the avoidance demo
(`lgmd_sim.apps.avoid`): writing a figure (`save_figure`), and an episode's world from
above (`draw_world`) in a box around it (`map_bounds`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lgmd_sim.core.fileio import write_files

__all__ = ["draw_world", "map_bounds", "save_figure"]

#: Margin of the map panels around the paths, obstacles and goal (m).
_PAD = 0.4


def save_figure(fig: Any, path: Path) -> None:
    """Write `fig` to `path` as a PNG, atomically."""
    # tight: an equal-aspect panel beside an outside legend otherwise clips its y label
    write_files({path: lambda tmp: fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")})


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
