"""Labelled jitter datasets: generate, verify, load.

- ``lgmd-sim dataset generate`` (`lgmd_sim.data.generate`: `GenerateConfig` ->
  `generate`; one episode: `lgmd_sim.data.episode`): episodes of the scenarios at
  several jitter levels, frames stored losslessly, per-frame ground truth in Parquet,
  resumable, byte-identical whatever runs it (local pool or Ray);
- ``lgmd-sim dataset verify`` (`lgmd_sim.data.verify`): counts, checksums and labels;
- `open` (`lgmd_sim.data.load`): episodes with frames and labels, filters, clips;
  `lgmd_sim.data.torch.WindowDataset` for PyTorch.

The layout (`lgmd_sim.data.layout`) follows the LeRobot dataset v3 conventions where
they fit; docs/guides/datasets.md describes it. Needs the 'data' extra (pyarrow).

>>> from lgmd_sim import data
>>> ds = data.open("my-dataset")
>>> for ep in ds.filter(outcome="near_miss"):
...     ep.frames(), ep.labels, ep.meta
>>> data.episodes("my-dataset:12")      # episode 12 (a folder alone: all of them)
"""

from lgmd_sim.data.layout import is_dataset
from lgmd_sim.data.load import Clip, Dataset, Episode, detect_inputs, episodes
from lgmd_sim.data.load import open_dataset as open

__all__ = ["Clip", "Dataset", "Episode", "detect_inputs", "episodes", "is_dataset", "open"]
