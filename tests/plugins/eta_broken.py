"""The worked example (examples/eta_lgmd.py, which must be on the path too) broken on purpose,
for the checker's output on a broken model in docs/guides/own-detector.md
(docs/experiments/tools/own_detector_page.py): its reset_streams resets every stream, not only
those it is given, as if one episode's end restarted all of a batch."""

from __future__ import annotations

import numpy as np
from eta_lgmd import EtaLGMD


class ResetEveryStream(EtaLGMD):
    """EtaLGMD whose reset_streams ignores ``idx`` and resets every stream."""

    def reset_streams(self, idx: np.ndarray) -> None:
        super().reset_streams(np.arange(len(self._fresh)))
