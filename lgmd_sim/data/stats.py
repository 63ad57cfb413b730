"""LeRobot's feature statistics (meta/stats.json): min, max, mean, std, count and the 1,
10, 50, 90 and 99 % quantiles, per component of each label column (`feature_stats`,
which ``lgmd-sim dataset generate`` writes) and per channel of a camera stream
(`image_stats`, which the LeRobot export adds)."""

from __future__ import annotations

import numpy as np

__all__ = ["QUANTILES", "feature_stats", "image_stats"]

#: The quantiles LeRobot's statistics hold, by key.
QUANTILES = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}


def feature_stats(labels) -> dict[str, dict[str, list]]:  # labels: pyarrow.Table
    """LeRobot's statistics of every column of `labels`, per component, over its finite
    values (NaN marks a missing value here, inf a time to collision that never comes, and
    normalising with either would be meaningless); None where a component has none.
    Booleans count as 0 and 1. ``count`` is the number of frames, as LeRobot's."""
    out = {}
    for name in labels.column_names:
        column = labels[name].combine_chunks()
        if hasattr(column.type, "list_size"):  # a fixed-size vector
            values = column.flatten().to_numpy(zero_copy_only=False).reshape(
                len(column), column.type.list_size)
        else:
            values = column.to_numpy(zero_copy_only=False).reshape(-1, 1)
        out[name] = _stats(values.astype(np.float64), labels.num_rows)
    return out


def _stats(values: np.ndarray, count: int) -> dict[str, list]:
    keys = ("min", "max", "mean", "std", *QUANTILES)
    out: dict[str, list] = {k: [] for k in keys}
    for component in values.T:
        finite = component[np.isfinite(component)]
        if not finite.size:
            for k in keys:
                out[k].append(None)
            continue
        got = [finite.min(), finite.max(), finite.mean(), finite.std(),
               *np.quantile(finite, list(QUANTILES.values()))]
        for k, v in zip(keys, got, strict=True):
            out[k].append(float(v))
    out["count"] = [count]
    return out


def image_stats(histogram: np.ndarray, frames: int) -> dict[str, list]:
    """LeRobot's per-channel statistics of a camera stream (values in [0, 1], each of
    shape (3, 1, 1)) from the (3, 256) histogram of its pixels: exact, quantiles included
    (the lowest level whose cumulative share reaches the quantile)."""
    levels = np.arange(256) / 255.0
    out: dict[str, list] = {k: [] for k in ("min", "max", "mean", "std", *QUANTILES)}
    for counts in histogram:
        total = counts.sum()
        mean = (counts * levels).sum() / total
        present = np.flatnonzero(counts)
        cumulative = np.cumsum(counts) / total
        got = {"min": levels[present[0]], "max": levels[present[-1]], "mean": mean,
               "std": np.sqrt((counts * (levels - mean) ** 2).sum() / total)}
        got |= {k: levels[np.searchsorted(cumulative, q)] for k, q in QUANTILES.items()}
        for k, v in got.items():
            out[k].append([[float(v)]])
    out["count"] = [frames]
    return out
