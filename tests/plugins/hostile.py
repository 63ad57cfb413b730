"""Plug-ins that break the contract in the ways a hostile or careless author would, for
the trust-boundary tests (tests/models/test_plugin_trust.py): each is `lgmd_plug.Blink` with one
fault."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from lgmd_plug import Blink

from lgmd_sim.core.params import in_range, param
from lgmd_sim.models import ModelParams


class Mutating(Blink):
    """Writes into its input frame (blacks it out) before reading it."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        grey[...] = 0
        return super().step_batch(grey, layers)


class NaNs(Blink):
    """Potentials that are all NaN."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        return np.full(len(grey), np.nan)


class Huge(Blink):
    """Potentials far outside the range the alarm threshold takes."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        return np.full(len(grey), 5e29)


class InitBoom(Blink):
    """Raises when it is built."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        raise RuntimeError("boom in init")


class StepBoom(Blink):
    """Raises at its fourth frame."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        self._frames = getattr(self, "_frames", 0) + 1
        if self._frames > 3:
            raise RuntimeError("boom in step")
        return super().step_batch(grey, layers)


class WrongShape(Blink):
    """Returns potentials of another shape."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        return np.full(len(grey) + 2, 0.6)


class Exits(Blink):
    """Ends the process from its step."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        sys.exit(3)


@dataclass(frozen=True)
class ShadowParams(ModelParams):
    gain: float = param(2.0, "test", check=in_range(0.0, 10.0), doc="shadows the front end")


class Shadow(Blink):
    """A parameter named like one of the base's (``gain``, the brightness front end)."""

    Params: ClassVar[type[ModelParams]] = ShadowParams


class LateBoom(Blink):
    """Raises at its 40th frame, after the checks a command runs first."""

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        self._frames = getattr(self, "_frames", 0) + 1
        if self._frames > 40:
            raise RuntimeError("boom late")
        return super().step_batch(grey, layers)
