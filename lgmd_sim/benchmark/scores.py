"""The benchmark's scores: one headline per track, in [0, 1], higher is better, and one
overall, each from the episodes' (or clips') records of an entry.

- goal (`goal_score`): success weighted by path efficiency, as Habitat's SPL: 1 for an
  episode that reaches the goal by the straight line, less the longer its path, 0 for one
  that collides or runs out of time (a robot that never moves scores 0);
- arena (`arena_score`): the share of the episode's encounters avoided (the Colias arena
  papers' figure; 1 with none), times the distance it travelled over the protocol's
  reference (the Oracle's mean on the same track), at most 1: avoiding by standing still
  scores 0;
- detection (`detection_score`): balanced accuracy, the mean of the hit rate on approaching
  clips and the silence rate on clips that do not loom: an entry that never alarms scores
  0.5, one that alarms from the first frame 0 (its first alarm comes before the window
  on every looming clip);
- overall: the mean of the goal and arena scores, what a robot does with the detector; the
  detection score stands beside it, so that entries without a detector (the Oracle, a
  policy) rank on the same scale.

A track's records reduce to per-seed parts (`Parts`): for each seed of the track, sums
whose ratios give the score, so that resampling the seeds (a bootstrap, the same draws for
every entry of a protocol) gives intervals, and the same draws for two entries a paired
comparison: both ran every seed, so the seeds' own difficulty cancels.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["CLOSED_LOOP", "TRACKS", "Parts", "Summary", "arena_score", "bootstrap",
           "compare", "detection_parts", "goal_score", "overall", "parts_of", "summarise"]

#: The closed-loop tracks, and every track, in the order a result lists them.
CLOSED_LOOP = ("goal", "arena")
TRACKS = (*CLOSED_LOOP, "detection")
#: The interval's coverage.
COVERAGE = 0.95


def goal_score(record: Mapping[str, Any]) -> float:
    """SPL of one goal episode: reached x straight line / max(path taken, straight line)."""
    if not record["goal_reached"]:
        return 0.0
    straight = float(record["straight_line_m"])
    return straight / max(float(record["distance_m"]), straight)


def arena_score(record: Mapping[str, Any], reference_m: float) -> float:
    """One arena episode's score: the share of its encounters avoided (1 with none) times
    its distance over `reference_m`, at most 1."""
    met = record["encounters"]
    avoided = record["avoided"] / met if met else 1.0
    return avoided * min(1.0, float(record["distance_m"]) / reference_m)


@dataclass(frozen=True)
class Parts:
    """A track's score by seed: ``sums`` (seeds, 2k) holds, per seed, k pairs (numerator,
    denominator); the score is the mean over the pairs of sum(numerators) /
    sum(denominators) over the seeds."""

    seeds: tuple[int, ...]
    sums: np.ndarray

    def score(self, rows: np.ndarray | None = None) -> np.ndarray | float:
        """The score (over the seeds, or over each row of seed indices `rows`: (B, S))."""
        totals = self.sums.sum(axis=0) if rows is None else self.sums[rows].sum(axis=1)
        ratios = totals[..., 0::2] / totals[..., 1::2]
        return float(ratios.mean()) if rows is None else ratios.mean(axis=-1)

    def to_json(self) -> dict[str, Any]:
        return {"seeds": list(self.seeds), "sums": self.sums.tolist()}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Parts:
        return cls(tuple(data["seeds"]), np.asarray(data["sums"], float))


def parts_of(records: Sequence[Mapping[str, Any]], score: Callable[[Mapping[str, Any]], float]
             ) -> Parts:
    """The parts of a closed-loop track: per seed, the sum of its episodes' `score` (one per
    jitter level) and their count."""
    by_seed: dict[int, list[float]] = {}
    for r in records:
        by_seed.setdefault(int(r["seed"]), []).append(score(r))
    seeds = tuple(sorted(by_seed))
    return Parts(seeds, np.array([[sum(by_seed[s]), len(by_seed[s])] for s in seeds], float))


def detection_parts(records: Sequence[Mapping[str, Any]]) -> Parts:
    """The parts of the detection track: per seed, hits and approaching clips, silences and
    clips that do not loom."""
    seeds = tuple(sorted({int(r["seed"]) for r in records}))
    index = {s: i for i, s in enumerate(seeds)}
    sums = np.zeros((len(seeds), 4))
    for r in records:
        i = index[int(r["seed"])]
        if r["approaching"]:
            sums[i, 0:2] += (r["outcome"] == "hit", 1)
        else:
            sums[i, 2:4] += (r["outcome"] != "false_alarm", 1)
    return Parts(seeds, sums)


def _draws(track: str, n_seeds: int, resamples: int, seed: int) -> np.ndarray:
    """The bootstrap's seed indices for `track` (resamples, n_seeds): the same for every
    entry of a protocol, so that two entries' resamples pair up."""
    rng = np.random.default_rng([seed, zlib.crc32(track.encode())])
    return rng.integers(0, n_seeds, (resamples, n_seeds))


def bootstrap(parts: Mapping[str, Parts], resamples: int, seed: int) -> dict[str, np.ndarray]:
    """Each track's score over `resamples` resamples of its seeds, and "overall" (the mean
    of the closed-loop tracks') where the entry has both."""
    out = {t: p.score(_draws(t, len(p.seeds), resamples, seed)) for t, p in parts.items()}
    if all(t in out for t in CLOSED_LOOP):
        out["overall"] = np.mean([out[t] for t in CLOSED_LOOP], axis=0)
    return out


def overall(parts: Mapping[str, Parts]) -> float | None:
    """The overall score: the mean of the goal and arena scores (None without both)."""
    if not all(t in parts for t in CLOSED_LOOP):
        return None
    return float(np.mean([parts[t].score() for t in CLOSED_LOOP]))


def _interval(draws: np.ndarray) -> list[float]:
    tail = (1 - COVERAGE) / 2 * 100
    return [float(v) for v in np.percentile(draws, [tail, 100 - tail])]


@dataclass(frozen=True)
class Summary:
    """An entry's headline scores with their bootstrap intervals, by track and overall."""

    scores: dict[str, float]
    intervals: dict[str, list[float]]


def summarise(parts: Mapping[str, Parts], resamples: int, seed: int) -> Summary:
    """The headline scores of `parts` (track -> `Parts`) and their intervals."""
    draws = bootstrap(parts, resamples, seed)
    scores = {t: parts[t].score() for t in TRACKS if t in parts}
    total = overall(parts)
    if total is not None:
        scores["overall"] = total
    return Summary(scores, {k: _interval(v) for k, v in draws.items()})


def compare(a: Mapping[str, Parts], b: Mapping[str, Parts], resamples: int, seed: int
            ) -> dict[str, dict[str, Any]]:
    """Entry `a` against `b`, paired on the seeds: per score both have, the difference
    a - b, its interval, and whether the interval excludes 0 (separable).

    Raises:
        ValueError: a track the two ran on other seeds (results of other protocols).
    """
    shared = [t for t in TRACKS if t in a and t in b]
    for t in shared:
        if a[t].seeds != b[t].seeds:
            raise ValueError(f"track {t}: the entries ran other seeds; compare results of "
                             "one protocol")
    da = bootstrap({t: a[t] for t in shared}, resamples, seed)
    db = bootstrap({t: b[t] for t in shared}, resamples, seed)
    out = {}
    for key in da:
        diff = da[key] - db[key]
        low, high = _interval(diff)
        point = (overall(a) - overall(b)) if key == "overall" else a[key].score() - b[key].score()
        out[key] = {"difference": float(point), "interval": [low, high],
                    "separable": bool(low > 0 or high < 0)}
    return out
