"""A researcher's plug-in, as the tests use it by its specs ("lgmd_plug:Blink"), by
`register` and by an entry point: a small but complete model with a search space, the
same without one, without state maps and without layers, and a controller."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from lgmd_sim.controllers import Controller
from lgmd_sim.core.params import CheckedParams, in_range, param
from lgmd_sim.models import LGMDModel, ModelParams, SearchRange, StateMap


@dataclass(frozen=True)
class BlinkParams(ModelParams):
    scale: float = param(20.0, "test", check=in_range(0.0, 1000.0), doc="gain of the change")


class Blink(LGMDModel):
    """A test detector: the potential rises with the mean frame change."""

    name: ClassVar[str] = "blink"
    Params: ClassVar[type[ModelParams]] = BlinkParams
    layer_names: ClassVar[tuple[str, ...]] = ("P",)
    presets: ClassVar[dict[str, dict[str, Any]]] = {"plain": {}, "fast": {"scale": 200.0}}
    search_space: ClassVar[dict[str, SearchRange]] = {"scale": SearchRange(1.0, 500.0)}

    params: BlinkParams

    def allocate(self, n: int, height: int, width: int) -> None:
        self._prev = np.zeros((n, height, width), np.float32)
        self._fresh = np.ones(n, bool)

    def reset_streams(self, idx: np.ndarray) -> None:
        self._fresh[idx] = True

    def state_maps(self) -> list[StateMap]:
        return [StateMap("_prev", "frame")]

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        now = grey.astype(np.float32)  # a copy: grey may be the caller's frames
        change = np.where(self._fresh[:, None, None], np.float32(0), np.abs(now - self._prev))
        self._prev, self._fresh[:] = now, False
        if layers is not None:
            layers["P"][...] = change
        return 1.0 / (1.0 + np.exp(-self.params.scale * change.mean(axis=(1, 2)) / 255.0))


class Untuned(Blink):
    """The same, declaring nothing to search."""

    search_space: ClassVar[dict[str, SearchRange]] = {}


class NoMaps(Untuned):
    """The same, listing no state maps: it runs without front ends only."""

    name: ClassVar[str] = "nomaps"
    state_maps = LGMDModel.state_maps


class Bare(Untuned):
    """The same, declaring no layers (legal: ``layer_names = ()``)."""

    name: ClassVar[str] = "bare"
    layer_names: ClassVar[tuple[str, ...]] = ()

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        return super().step_batch(grey, None)


@dataclass(frozen=True)
class CreepParams(CheckedParams):
    pass


class Creep(Controller):
    """Creeps forward."""

    Params = CreepParams

    def act(self, obs: Any, info: Any) -> np.ndarray:
        return np.array([0.3, 0.0], np.float32)
