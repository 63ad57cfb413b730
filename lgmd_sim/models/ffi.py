"""F(ONn)-LGMD and F(OFFp)-LGMD: the oLGMD, LGMD2 with contrast polarity-specific FFI.

The paper's [37] is read as the oLGMD of Gao, Liu, Wang & Fu (Biomimetics 2024, "A
computationally efficient collision-detection neuronal model with contrast
polarity-specific feed-forward inhibition"), whose published Python model is
Ryannnice/Supplementary_Materials_FFI_ON_OFF, Core_of_Source_Code/Computer_oLGMD_Python/
optimized_LGMD.py. It is `lgmd_sim.models.lgmd2.LGMD2` with other values and switches:
per-channel PM with a 10 ms two-tap filter, a feed-forward gate on each channel, a global
FFI, no S_on S_off term, decaying luminance persistence, S on the frame's interior only,
a fixed 53 ms frame interval.

That file is one model that gates both channels; the names F(ONn) and F(OFFp) are not
in it. So both `f_on` and `f_off` are that model by default (preset ``published``);
preset ``v0.1`` keeps this project's first reading, in which F(ONn) gates only the ON
channel and F(OFFp) only the OFF channel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from lgmd_sim.core.params import param
from lgmd_sim.models.base import ModelParams
from lgmd_sim.models.lgmd2 import LGMD2, LGMD2Params
from lgmd_sim.models.sources import SOURCES

__all__ = ["FFIParams", "FOffLGMD", "FOnLGMD"]

_OL = SOURCES["olgmd"]


def _field(name: str, default: Any, source: str) -> Any:
    """LGMD2's parameter ``name`` (its check and doc) with the oLGMD's default and source."""
    meta = LGMD2Params.__dataclass_fields__[name].metadata
    return param(default, source, check=meta["check"], doc=meta["doc"])


@dataclass(frozen=True)
class FFIParams(LGMD2Params):
    """Parameters of the F(ON)/F(OFF) LGMDs: LGMD2's, with optimized_LGMD.py's values."""

    c_sig: float = _field("c_sig", 0.6, f"{_OL} (a5)")
    border: str = _field("border", "interior", f"{_OL}: S only for 1 <= x <= H-2, "
                         "1 <= y <= W-2; Ce by cv2.filter2D (BORDER_REFLECT_101)")
    persistence: str = _field("persistence", "decaying", f"{_OL}: P(t) = Z(t) - Z(t-1) + "
                              "a11 P(t-1) + a12 P(t-2), a11 = 1 / (1 + exp(t - 1)), "
                              "a12 = 1 / (1 + exp(t - 2))")
    dt: float | None = _field("dt", 53.0, f"{_OL} (self.t = 53.0; 1000 / fps commented out)")
    tau_pm: float = _field("tau_pm", 10.0, f"{_OL} (a4 = t / (10 + t))")
    pm_filter: str = _field("pm_filter", "two-tap", f"{_OL}: PM_on = a4 pmon + (1 - a4) "
                            "pon0, pon0 the last frame's unfiltered pmon")
    pm_weights: str = _field("pm_weights", "per-channel", f"{_OL}: w1 from PM_on, w2 from "
                             "PM_ff")
    t_pm: float = _field("t_pm", 6.0, f"{_OL} (Tpm)")
    w_off_min: float = _field("w_off_min", 0.3, f"{_OL} (w4)")
    onoff_product: float = _field("onoff_product", 0.0, f"{_OL} (o3 = 0)")
    ffi_channels: str = _field("ffi_channels", "both", f"{_OL}: PM_on >= oon and "
                               "PM_ff >= ooff gate S_on and S_off")
    global_ffi_base: float | None = _field("global_ffi_base", 10.0, f"{_OL}: k = 0.5 "
                                           "where AIM(t) >= 10 + 0.02 AIM(t-1)")
    t_sfa: float = _field("t_sfa", 0.002, f"{_OL} (Tsfa)")


#: This project's first reading (v0.1): LGMD2's machinery as then read (low-passed
#: previous frames, SFA following K, whole-field PM low-passed with LGMD2's 90 ms), the
#: oLGMD's T_pm, W_off baseline, C_sig and gate level, and a gate on one channel that
#: zeroes its S only.
_V01: dict[str, Any] = {
    "border": "replicate", "persistence": "none", "dt": None, "dt_integer": False,
    "tau_pm": 90.0, "pm_filter": "low-pass", "pm_weights": "whole-field",
    "inhibition_filter": "low-pass", "onoff_product": 1.0, "ffi_gates_history": False,
    "global_ffi_base": None, "t_sfa": 0.003, "sfa_rise": "follow",
}


class _OLGMD(LGMD2):
    """The oLGMD: LGMD2 with `FFIParams`. F(ONn) and F(OFFp) differ only in the channel
    their v0.1 preset gates (`_presets`), so each is this class under its own name."""

    Params: ClassVar[type[ModelParams]] = FFIParams

    params: FFIParams


def _presets(v01_channel: str) -> dict[str, dict[str, Any]]:
    """The presets of the oLGMD named after ``v01_channel``, the one channel v0.1 gates."""
    return {
        "published": {},  # optimized_LGMD.py (PM_off from the OFF mean: its bug fixed)
        "v0.1": {**_V01, "ffi_channels": v01_channel},
    }


class FOnLGMD(_OLGMD):
    """F(ONn)-LGMD: the oLGMD (both channels gated); v0.1 gates the ON channel only."""

    name: ClassVar[str] = "f_on"
    presets: ClassVar[dict[str, dict[str, Any]]] = _presets("on")


class FOffLGMD(_OLGMD):
    """F(OFFp)-LGMD: the oLGMD (both channels gated); v0.1 gates the OFF channel only."""

    name: ClassVar[str] = "f_off"
    presets: ClassVar[dict[str, dict[str, Any]]] = _presets("off")
