"""The eta function of the LGMD, from frames: a model of your own (docs/guides/own-detector.md).

Gabbiani, Krapp & Laurent (1999, J Neurosci 19:1122) found that the locust LGMD's firing
rate during an approach follows

    eta(t) = C * theta'(t - delta) * exp(-alpha * theta(t - delta)),

theta the object's angular size and theta' its rate of change: the rate peaks a fixed
delay delta (15-35 ms) after theta reaches the threshold angle theta_thr = 2 atan(1 / alpha)
(15 to 40 degrees across animals), whatever the object's size and speed. Gabbiani et al.
(2002, Nature 420:320) showed the LGMD computes the product as exp(log theta' - alpha theta).

From frames alone, per stream and frame t (grey levels 0..255):

- P = |L(t) - L(t-1)| (0 on a stream's first frame), the LGMD models' P layer; a pixel
  counts where P > ``level``;
- theta, the angular diameter of the changing region: its P-weighted spread about its
  centroid, r = sqrt(var_x + var_y) pixels (the radius of a thin ring of change, which a
  solid object's moving outline is), theta = 2 atan(r / f), f = H / (2 tan(fovy / 2)) the
  focal length in pixels. It holds its value on a frame where no pixel counts;
- theta is low-passed with time constant ``tau`` frames (a stream's first estimate taken as
  it is), and theta' = theta(t) - theta(t-1) of the low-passed theta, per frame: the pixel
  grid makes theta grow in steps of a pixel, which the low-pass spreads over time;
- eta as above, delta in frames, rectified (a firing rate is not negative), and the
  potential 1 / (1 + exp(-eta)), in [0.5, 1) as the threshold expects.

Why theta' and not the mean of |P|, the LGMD models' excitation: that grows with the
outline's length and contrast as well as its speed, and is the same for an approach and a
recession (the changes of one are those of the other played backwards); theta' is signed
and free of contrast, as Gabbiani et al. (1999) found the threshold angle to be.

Limits: one object on a plain background. Texture, other moving things or the camera's own
motion spread the change over the frame, so theta reads the whole field and theta' little
(the "+image" front end removes the camera's rotation, not its translation); an object
entering or leaving the view makes theta jump (a false peak on entry); theta is measured
about the object's centroid, so an object cut by the frame's edge reads too small. An
object a few pixels across grows in steps of a pixel (2 atan(1 / f) radians, about 1 degree
in frames 64 pixels high), which even low-passed can cross the threshold: the model wants
frames of 128 pixels or more. The low-pass delays the peak by about ``tau`` frames besides
``delta``.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from lgmd_sim.core.params import in_range, int_in_range, param, positive
from lgmd_sim.models import LGMDModel, ModelParams, SearchRange, StateMap

GABBIANI_1999 = "Gabbiani, Krapp & Laurent 1999, J Neurosci 19:1122"


@dataclass(frozen=True)
class EtaParams(ModelParams):
    """Parameters of the eta-function LGMD; defaults: preset ``gabbiani``."""

    threshold: float = param(
        0.8, "our choice: the built-in LGMDs' threshold of their sigmoid potential; here "
        "eta = 1.39", check=in_range(0.5, 1.0), doc="alarm when the potential exceeds this")

    alpha: float = param(
        4.5, f"{GABBIANI_1999}: alpha = 1 / tan(theta_thr / 2), theta_thr 15-40 deg across "
        "animals; 4.5 gives 25 deg", check=positive,
        doc="size inhibition exp(-alpha theta), theta in radians: the potential peaks as "
            "theta reaches 2 atan(1 / alpha)")
    delta: int = param(
        1, f"{GABBIANI_1999}: the peak 15-35 ms after theta_thr; 1 frame at 30 fps",
        check=int_in_range(0, 30), doc="delay delta of eta, in frames")
    c: float = param(
        1500.0, "our choice: eta's peak, C theta' exp(-alpha theta_thr), is about 2 "
        "(potential 0.88) for an approach at l/|v| = 10 frames, 1/3 s at 30 fps",
        check=positive, doc="gain C of eta, per radian a frame")
    tau: float = param(
        8.0, "our choice: spreads a pixel's step of theta over 0.27 s at 30 fps",
        check=in_range(1.0, 1000.0), doc="time constant of theta's low-pass, in frames (1: "
                                         "none)")
    level: float = param(
        8.0, "our choice: above the grey-level rounding of rendered edges",
        check=in_range(0.0, 255.0), doc="a pixel's change counts towards theta above this")


class EtaLGMD(LGMDModel):
    """The eta function of the LGMD (Gabbiani et al. 1999): angular growth times exp(-size)."""

    name: ClassVar[str] = "eta"
    Params: ClassVar[type[ModelParams]] = EtaParams
    layer_names: ClassVar[tuple[str, ...]] = ("P",)
    presets: ClassVar[dict[str, dict[str, Any]]] = {"gabbiani": {}}
    # alpha over the threshold angles Gabbiani et al. (1999) report, 15-40 deg
    search_space: ClassVar[dict[str, SearchRange]] = {
        "alpha": SearchRange(2.7, 7.6, log=False), "c": SearchRange(150.0, 15000.0),
        "tau": SearchRange(2.0, 16.0)}

    params: EtaParams

    def allocate(self, n: int, height: int, width: int) -> None:
        self._prev = np.zeros((n, height, width), np.float32)
        self._fresh = np.ones(n, bool)  # no previous frame yet
        self._theta = np.zeros(n)  # the last estimate, held while nothing changes
        self._smooth = np.zeros(n)  # theta low-passed
        self._seen = np.zeros(n, bool)  # theta estimated at least once
        # (theta, theta') of this frame and of the delta frames before it, newest first
        self._line = np.zeros((n, self.params.delta + 1, 2))
        self._ys, self._xs = np.arange(height, dtype=float), np.arange(width, dtype=float)
        self._focal = height / (2 * np.tan(np.radians(self.params.fovy) / 2))

    def reset_streams(self, idx: np.ndarray) -> None:
        self._fresh[idx] = True
        self._theta[idx] = self._smooth[idx] = 0.0
        self._seen[idx] = False
        self._line[idx] = 0.0

    def state_maps(self) -> list[StateMap]:
        return [StateMap("_prev", "frame")]

    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        p = self.params
        frame = grey.astype(np.float32)
        self._prev[self._fresh] = frame[self._fresh]
        self._fresh[:] = False
        change = np.abs(frame - self._prev)
        self._prev = frame
        if layers is not None:
            layers["P"][:] = change
        weight = np.where(change > p.level, change, 0.0).astype(np.float64)
        rows, cols = weight.sum(axis=2), weight.sum(axis=1)
        total = rows.sum(axis=1)
        counted = total > 0
        spread = _variance(rows, self._ys, total) + _variance(cols, self._xs, total)
        self._theta = np.where(counted, 2 * np.arctan(np.sqrt(spread) / self._focal),
                               self._theta)
        first = counted & ~self._seen
        self._seen |= counted
        smooth = np.where(first, self._theta,
                          self._smooth + (self._theta - self._smooth) / p.tau)
        growth = np.where(first, 0.0, smooth - self._smooth)
        self._smooth = smooth
        self._line = np.roll(self._line, 1, axis=1)
        self._line[:, 0, 0], self._line[:, 0, 1] = smooth, growth
        size, speed = self._line[:, p.delta, 0], self._line[:, p.delta, 1]
        eta = p.c * np.maximum(speed, 0.0) * np.exp(-p.alpha * size)
        return 1.0 / (1.0 + np.exp(-eta))


def _variance(mass: np.ndarray, at: np.ndarray, total: np.ndarray) -> np.ndarray:
    """Per stream, the variance of positions `at` weighted by `mass` (N, len(at)) of sum
    `total`; 0 where the total is 0."""
    safe = np.where(total > 0, total, 1.0)
    mean = (mass * at).sum(axis=1) / safe
    return np.maximum((mass * at**2).sum(axis=1) / safe - mean**2, 0.0)


def main() -> None:
    """`python eta_lgmd.py --help` says what this file is and how lgmd-sim uses it; run
    without options it does nothing: a plug-in is imported, not run."""
    # a copy under another name or in another folder (the guide's "Make it yours") is
    # named as it is
    spec = f"{Path(__file__).stem}:{EtaLGMD.__name__}"
    folder = os.path.relpath(Path(__file__).parent)
    parser = argparse.ArgumentParser(
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=f"{__doc__.splitlines()[0]}\n\n"
        "A detector plug-in: running this file does nothing. lgmd-sim imports it by its\n"
        f"spec, {spec}, with its folder on PYTHONPATH. Check it, then name it\n"
        "wherever a model goes:\n\n"
        f"  PYTHONPATH={folder} lgmd-sim models --check {spec}\n"
        f"  PYTHONPATH={folder} lgmd-sim detect clip.mkv --models {spec},lgmd1")
    parser.parse_args()


if __name__ == "__main__":
    main()
