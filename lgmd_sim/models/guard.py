"""What keeps a plug-in model's faults its own: a plug-in (any `LGMDModel` subclass outside
lgmd_sim) is the researcher's code, run by every command, so the base runs its hooks
through `run_hook` (its errors, sys.exit included, become one `PluginError` naming it)
and checks its potentials every step (`potentials_fault`), as `check_model` checks them
once. The built-ins' own errors pass unchanged: a fault of theirs is lgmd-sim's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["PluginError", "is_plugin", "plugin_label", "potentials_fault", "run_hook"]


class PluginError(ValueError):
    """A plug-in model's own code failed, or broke the contract, while it ran: one line
    naming the plug-in (its "module:Class"), the hook and what went wrong; the plug-in's
    own exception is the cause. The built-ins' errors pass unchanged: a fault of theirs is
    lgmd-sim's, and keeps its traceback."""

    def __init__(self, model: type | str, hook: str, reason: str) -> None:
        label = model if isinstance(model, str) else plugin_label(model)
        super().__init__(label, hook, reason)  # its arguments: it pickles (from a worker)
        self.model, self.hook, self.reason = label, hook, reason

    def __str__(self) -> str:
        return f"plug-in model {self.model}: {self.hook}: {self.reason}"


def is_plugin(cls: type) -> bool:
    """Whether model class `cls` is a plug-in's (any class outside lgmd_sim)."""
    return not cls.__module__.startswith("lgmd_sim.")


def plugin_label(cls: type) -> str:
    """A model class as its spec names it: "module:Class"."""
    return f"{cls.__module__}:{cls.__qualname__}"


def run_hook(cls: type, hook: str, call: Any, *args: Any, **kwargs: Any) -> Any:
    """``call(*args, **kwargs)``, the hook `hook` of model class `cls`; what a plug-in's
    code raises, sys.exit included, becomes a `PluginError` naming it."""
    try:
        return call(*args, **kwargs)
    except (Exception, SystemExit) as exc:
        if not is_plugin(cls) or isinstance(exc, PluginError) or _ours(exc):
            raise
        raise PluginError(cls, hook, _raised(exc)) from exc


def _ours(exc: BaseException) -> bool:
    """Whether `exc` is a ValueError lgmd-sim raised itself (the base refusing an input
    or a setting, in one line naming it), not one of the plug-in's code."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return isinstance(exc, ValueError) and tb is not None and str(
        tb.tb_frame.f_globals.get("__name__", "")).startswith("lgmd_sim.")


def _raised(exc: BaseException) -> str:
    if isinstance(exc, SystemExit):
        return f"it called sys.exit({exc.code!r})"
    text = " ".join(str(exc).split())
    if isinstance(exc, ValueError) and "read-only" in text:  # NumPy's, on a write to grey
        return ("it writes into its input frames, which are read-only (every model of a "
                "run reads the same frames): copy what it changes, grey.astype(np.float32)")
    return f"raised {type(exc).__name__}{': ' + text[:300] if text else ''}"


def potentials_fault(potentials: Any, n: int, threshold_check: Any,
                     frame: int | None = None) -> str | None:
    """What of one step's `potentials` (of frame `frame`, where known) breaks the contract:
    a float array of `n` finite values that the alarm threshold's check, `threshold_check`,
    takes; None if nothing."""
    at = "" if frame is None else f" at frame {frame}"
    if not (isinstance(potentials, np.ndarray) and potentials.shape == (n,)
            and np.issubdtype(potentials.dtype, np.floating)):
        what = (f"an array of {potentials.dtype} of shape {potentials.shape}"
                if isinstance(potentials, np.ndarray) else type(potentials).__name__)
        return (f"step_batch returned {what}{at}, not a float array of shape ({n},): one "
                "potential per stream")
    lo, hi = float(potentials.min()), float(potentials.max())  # the threshold takes a range
    if math.isfinite(lo) and math.isfinite(hi) and not (
            threshold_check(lo) or threshold_check(hi)):
        return None
    for i, v in enumerate(potentials.tolist()):  # the first at fault, to name its stream
        where = f"{at}, stream {i}," if frame is not None else f" of stream {i}"
        if not math.isfinite(v):
            return f"potential {v!r}{where} is not finite"
        error = threshold_check(v)
        if error:
            return (f"potential {v:.6g}{where} is outside the range the alarm threshold takes "
                    f"(a threshold {error}): a model whose potentials span another range "
                    "redefines threshold with its own check")
    return None
