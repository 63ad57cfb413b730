"""The compensation loop: a model's stored maps (its `state_maps`) warped into the current
camera frame, stream by stream, and its previous frame scaled by the brightness gain.

The motion comes from the model's front end (`lgmd_sim.models.stabilize`) or from its
caller (``step(frame, motion=...)``, a `lgmd_sim.models.warp.Motion`);
`lgmd_sim.models.base.LGMDModel.step` runs the loop on every frame after the first that
has one, before the model takes the frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from lgmd_sim.models.guard import run_hook
from lgmd_sim.models.warp import Plan, apply_plan, fill_pad_columns, homography_plan

__all__ = ["Compensation"]


class Compensation:
    """The compensation of one model's streams. It keeps the sampling plan and its scratch
    array from frame to frame, made anew when the frame size changes."""

    def __init__(self) -> None:
        self._plan: Plan | None = None
        self._scratch: np.ndarray | None = None

    def warp(self, model: Any, grey: np.ndarray, hs: np.ndarray | None,
             gains: np.ndarray | None, horizons: np.ndarray | None,
             grounds: np.ndarray | None) -> None:
        """Warp every stored map of `model` (an `LGMDModel`: its `state_maps`) into the
        current frame `grey` (N, H, W) by the streams' homographies `hs` (N, 3, 3) (and
        below their `horizons`, by `grounds`: see `Motion`) and scale the previous frame by
        their `gains` ((N, 1, 1) or (N, H, W))."""
        n, height, width = grey.shape
        if gains is not None and gains.shape[1:] not in ((1, 1), (height, width)):
            raise ValueError(f"{model.name}: gain fields of {gains.shape[1]}x{gains.shape[2]} "
                             f"for frames of {height}x{width}")
        maps = run_hook(type(model), "state_maps", model.state_maps)
        for m in maps:  # a previous frame holds interpolated grey levels from now on
            if m.fill == "frame" and getattr(model, m.attr).dtype != np.float32:
                setattr(model, m.attr, getattr(model, m.attr).astype(np.float32))
        if self._plan is None or self._plan.uncovered.shape != (height, width):
            self._plan = Plan(height, width)
            self._scratch = np.zeros((height + 1, width + 1), np.float32)
        plan, identity, moved = self._plan, np.eye(3), False
        for i in range(n):
            gain = None if gains is None or (gains[i] == 1).all() else np.broadcast_to(
                gains[i], (height, width))  # a gain of 1 changes exactly nothing
            if hs is not None and not (np.array_equal(hs[i], identity) and horizons is None):
                moved = True
                homography_plan(hs[i], plan, None if horizons is None else horizons[i],
                                None if grounds is None else grounds[i])
                fill = grey[i].astype(np.float32)  # uncovered: P = 0, whatever the gain
                for m in maps:
                    view = getattr(model, m.attr)[i]
                    if m.padded is not None:
                        view = view[..., :height, 1:width + 1]
                    frame = m.fill == "frame"
                    for k in np.ndindex(view.shape[:-2]):
                        apply_plan(plan, view[k], fill if frame else None, self._scratch,
                                   gain if frame else None)
            elif gain is not None:
                for m in maps:
                    if m.fill == "frame":
                        view = getattr(model, m.attr)[i]
                        view *= gain
        if moved:
            for m in maps:
                if m.padded is not None:
                    fill_pad_columns(getattr(model, m.attr)[..., :height, :], width, m.padded)
            run_hook(type(model), "maps_moved", model.maps_moved)
