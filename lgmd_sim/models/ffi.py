"""F(ONn)-LGMD and F(OFFp)-LGMD: LGMD2-style models with polarity-specific feed-forward inhibition.

The paper's [37] is read as the oLGMD of Chang, Fu et al. (Biomimetics 2024, "A
computationally efficient collision-detection neuronal model with contrast
polarity-specific feed-forward inhibition"), source Ryannnice/
Supplementary_Materials_FFI_ON_OFF, optimized_LGMD.py. Its ON/OFF channels, delayed
inhibition, G layer and SFA are LGMD2's (`lgmd_sim.models.lgmd2`) with other values; the
feed-forward inhibition (FFI) lets a channel's S through only while that channel's
low-passed mean activity PM_on / PM_off reaches ``ffi_gate``.

Which channel carries the FFI is what tells the two apart. Our reading (an interpretation,
docs/models.md): F(ONn) gates the ON channel, F(OFFp) the OFF channel; the other channel
passes ungated.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from lgmd_sim.models.base import ModelParams
from lgmd_sim.models.lgmd2 import LGMD2, LGMD2Params
from lgmd_sim.params import finite, non_negative, param, positive

__all__ = ["FFIParams", "FOffLGMD", "FOnLGMD"]

_SRC = "Ryannnice/Supplementary_Materials_FFI_ON_OFF optimized_LGMD.py (oLGMD)"
_LGMD2 = "ours: LGMD2's value (lgmd2OpenSource.cs); baselines.md gives none for the oLGMD"


@dataclass(frozen=True)
class FFIParams(LGMD2Params):
    """Parameters of the F(ON)/F(OFF) LGMDs: LGMD2's, with the oLGMD's values and the gate."""

    tau_pm: float = param(90.0, _LGMD2, check=non_negative,
                          doc="time constant (ms) of the low-passes of mean |P| (PM) and of "
                              "the mean ON / OFF activity (PM_on, PM_off)")
    t_pm: float = param(6.0, _SRC, check=positive, doc="T_pm: W = max(w_min, PM / t_pm)")
    w_on_min: float = param(1.0, f"{_SRC}: ON inhibition bias", check=non_negative,
                            doc="smallest inhibition weight of the ON channel")
    w_off_min: float = param(0.3, f"{_SRC}: OFF inhibition bias", check=non_negative,
                             doc="smallest inhibition weight of the OFF channel")
    c_sig: float = param(0.6, _SRC, check=positive,
                         doc="C_sig: the potential is sigmoid(sum G / (n_cells * c_sig))")
    t_sfa: float = param(0.003, _LGMD2, check=finite,
                         doc="SFA: a rise of K by at most t_sfa counts as no rise (adapt)")
    ffi_gate: float = param(
        1.15, _SRC, check=non_negative,
        doc="the gated channel's S passes only while its low-passed mean activity (PM_on or "
            "PM_off, time constant tau_pm) is at least this")


class _FFILGMD(LGMD2):
    """LGMD2 machinery with the FFI gate on one channel, named by ``ffi_channel``.

    The reported potential is the adapted one (after SFA). The gate zeroes the channel's S
    only; its low-passes keep running. Spikes (exp(4 (K - 0.78)) summed over 4 frames) are
    not modelled.
    """

    Params: ClassVar[type[ModelParams]] = FFIParams
    ffi_channel: ClassVar[str]

    params: FFIParams

    def _gates(self, pm_on: np.ndarray, pm_off: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        gate = self.params.ffi_gate
        if self.ffi_channel == "on":
            return (pm_on >= gate).astype(np.float64), np.ones_like(pm_off)
        return np.ones_like(pm_on), (pm_off >= gate).astype(np.float64)


class FOnLGMD(_FFILGMD):
    """F(ONn)-LGMD: the feed-forward inhibition gates the ON channel (our reading)."""

    name: ClassVar[str] = "f_on"
    ffi_channel: ClassVar[str] = "on"


class FOffLGMD(_FFILGMD):
    """F(OFFp)-LGMD: the feed-forward inhibition gates the OFF channel (our reading)."""

    name: ClassVar[str] = "f_off"
    ffi_channel: ClassVar[str] = "off"
