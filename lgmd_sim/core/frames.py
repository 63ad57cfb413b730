"""The one frame convention shared by models, metrics and tools: grey from colour."""

from __future__ import annotations

import cv2
import numpy as np


def to_grey(frame: np.ndarray, what: str = "frame") -> np.ndarray:
    """A grey (H, W) view of a grey (H, W), (H, W, 1) or RGB (H, W, 3) frame.

    Colour becomes ITU-R BT.601 luma, as OpenCV computes it (and the published LGMD code
    uses); uint8 stays uint8 (rounded), other types become float32. Other shapes raise
    ValueError naming `what`.
    """
    a = np.asarray(frame)
    if a.ndim == 3 and a.shape[-1] == 1:
        a = a[..., 0]
    elif a.ndim == 3 and a.shape[-1] == 3:
        work = a if a.dtype == np.uint8 else a.astype(np.float32)
        a = cv2.cvtColor(np.ascontiguousarray(work), cv2.COLOR_RGB2GRAY)
    if a.ndim != 2 or min(a.shape) < 1:
        raise ValueError(f"{what}: expected a grey (H, W) or colour (H, W, 3) frame, "
                         f"got shape {np.shape(frame)}")
    return a
