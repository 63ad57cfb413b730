"""A PyTorch `Dataset` of fixed-length windows of a dataset's episodes (the 'rl' extra).

>>> from lgmd_sim import data
>>> from lgmd_sim.data.torch import WindowDataset
>>> windows = WindowDataset(data.open("my-dataset"), length=16, columns=["threat_ttc"])
>>> frames, labels = windows[0]     # uint8 (16, H, W, 3), float32 (16, 1)
>>> loader = torch.utils.data.DataLoader(windows, batch_size=8, shuffle=True)
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence

import numpy as np

from lgmd_sim.core.extras import require
from lgmd_sim.data.load import Dataset

torch = require("torch", "rl")

__all__ = ["WindowDataset"]

#: Label columns returned by default: when, how far and how fast the threat comes.
DEFAULT_COLUMNS = ("threat_distance", "threat_ttc", "threat_closing_speed", "collision")


class WindowDataset(torch.utils.data.Dataset):
    """Every `length`-frame window (starts `stride` apart) of every episode of `dataset`.

    Item i is ``(frames, labels)``: frames a uint8 tensor (length, H, W, 3) (with `noise`,
    that noise variant of them), labels a float32 tensor (length, len(columns)) of the
    label columns named in `columns` (booleans as 0 / 1). The last `cache` decoded
    episodes are kept, so windows of one episode read in a row decode it once.
    """

    def __init__(self, dataset: Dataset, length: int, *, stride: int = 1,
                 columns: Sequence[str] = DEFAULT_COLUMNS, noise: str | None = None,
                 cache: int = 2) -> None:
        self.dataset = dataset
        self.length = length
        self.columns = list(columns)
        self.noise = noise
        self.index = dataset.windows(length, stride)
        self._cache: OrderedDict[int, tuple[np.ndarray, np.ndarray]] = OrderedDict()
        self._cache_size = max(1, cache)

    def __len__(self) -> int:
        return len(self.index)

    def _episode(self, position: int) -> tuple[np.ndarray, np.ndarray]:
        if position in self._cache:
            self._cache.move_to_end(position)
            return self._cache[position]
        ep = self.dataset[position]
        labels = ep.read_labels(self.columns)
        values = np.stack([labels[c].to_numpy(zero_copy_only=False).astype(np.float32)
                           for c in self.columns], axis=1)
        self._cache[position] = (ep.frames(self.noise), values)
        if len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return self._cache[position]

    def __getitem__(self, i: int):
        position, start = self.index[i]
        frames, values = self._episode(position)
        end = start + self.length
        return torch.from_numpy(frames[start:end].copy()), torch.from_numpy(values[start:end])
