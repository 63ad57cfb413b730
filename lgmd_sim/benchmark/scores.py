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

Protocol 2 scores detection on the robot's own camera (`lgmd_sim.benchmark.camera`) and
keeps the synthetic clips as the "stimuli" track, outside the overall score; its parts
hold each jitter level apart, which gives every entry its dose-response: the score at
each level, and J50 (`j50`), the level at which the score falls to half its jitter-0 one.

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
           "compare", "detection_parts", "goal_score", "j50", "overall", "parts_of",
           "summarise"]

#: The closed-loop tracks, and every track, in the order a result lists them.
CLOSED_LOOP = ("goal", "arena")
TRACKS = (*CLOSED_LOOP, "detection", "stimuli")
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
    sum(denominators) over the seeds. With `levels` (protocol 2), the pairs are those of
    each jitter level in turn, as many a level, and `level_scores` gives each level's."""

    seeds: tuple[int, ...]
    sums: np.ndarray
    levels: tuple[float, ...] | None = None

    def _ratios(self, rows: np.ndarray | None) -> np.ndarray:
        """Each pair's ratio; NaN for a pair with nothing to count (no window frame among
        the camera clips drawn), which the means leave out."""
        totals = self.sums.sum(axis=0) if rows is None else self.sums[rows].sum(axis=1)
        with np.errstate(invalid="ignore"):
            return totals[..., 0::2] / totals[..., 1::2]

    def score(self, rows: np.ndarray | None = None) -> np.ndarray | float:
        """The score (over the seeds, or over each row of seed indices `rows`: (B, S))."""
        ratios = self._ratios(rows)
        return float(np.nanmean(ratios)) if rows is None else np.nanmean(ratios, axis=-1)

    def level_scores(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The score at each jitter level (levels,), or per row of `rows` (B, levels)."""
        if self.levels is None:
            raise ValueError("these parts do not hold the jitter levels apart (protocol 1)")
        ratios = self._ratios(rows)
        return np.nanmean(ratios.reshape(*ratios.shape[:-1], len(self.levels), -1), axis=-1)

    def to_json(self) -> dict[str, Any]:
        return {"seeds": list(self.seeds), "sums": self.sums.tolist(),
                **({"levels": list(self.levels)} if self.levels is not None else {})}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Parts:
        levels = data.get("levels")
        return cls(tuple(data["seeds"]), np.asarray(data["sums"], float),
                   None if levels is None else tuple(float(j) for j in levels))


def parts_of(records: Sequence[Mapping[str, Any]], score: Callable[[Mapping[str, Any]], float],
             levels: Sequence[float] | None = None) -> Parts:
    """The parts of a closed-loop track: per seed, the sum of its episodes' `score` (one per
    jitter level) and their count; with `levels`, a pair (score, 1) for each level."""
    by_seed: dict[int, dict[float, float]] = {}
    for r in records:
        by_seed.setdefault(int(r["seed"]), {})[float(r["jitter"])] = score(r)
    seeds = tuple(sorted(by_seed))
    if levels is None:
        sums = [[sum(by_seed[s].values()), len(by_seed[s])] for s in seeds]
        return Parts(seeds, np.array(sums, float))
    sums = [[v for j in levels for v in (by_seed[s][float(j)], 1.0)] for s in seeds]
    return Parts(seeds, np.array(sums, float), tuple(float(j) for j in levels))


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


def j50(level_scores: np.ndarray, levels: Sequence[float]) -> np.ndarray:
    """The jitter level at which a score first falls to half its jitter-0 score, linear
    between the levels (`level_scores`: (..., levels), `levels` ascending from 0): inf
    where it never does within the levels, NaN where the jitter-0 score is 0."""
    s = np.asarray(level_scores, float)
    x = np.asarray(levels, float)
    half = s[..., :1] / 2
    below = s <= half
    below[..., 0] = False  # the jitter-0 score is the reference, not a fall
    first = np.where(below.any(axis=-1), below.argmax(axis=-1), 0)
    i = np.maximum(first, 1)[..., None]
    s0 = np.take_along_axis(s, i - 1, -1)[..., 0]
    s1 = np.take_along_axis(s, i, -1)[..., 0]
    i = i[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(s0 > s1, (s0 - half[..., 0]) / (s0 - s1), 0.0)
        out = np.where(below.any(axis=-1), x[i - 1] + t * (x[i] - x[i - 1]), np.inf)
    return np.where(s[..., 0] > 0, out, np.nan)


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


def dose_response(parts: Mapping[str, Parts], resamples: int, seed: int
                  ) -> dict[str, Any] | None:
    """The closed-loop headline by jitter level (the mean of the goal and arena scores at
    each level; the goal's alone for a policy) and its J50 (`j50`) with a bootstrap
    interval, from parts that hold the levels apart (protocol 2); None otherwise.

    J50 is inf where the score never halves within the levels (an interval's end too), NaN
    where the jitter-0 score is 0 (then no fall can be told)."""
    tracks = [t for t in CLOSED_LOOP if t in parts]
    if not tracks or any(parts[t].levels is None for t in tracks):
        return None
    levels = parts[tracks[0]].levels
    point = np.mean([parts[t].level_scores() for t in tracks], axis=0)
    draws = np.mean([parts[t].level_scores(_draws(t, len(parts[t].seeds), resamples, seed))
                     for t in tracks], axis=0)
    tail = (1 - COVERAGE) / 2
    # no interpolation between resamples: an end may be inf (never halves)
    low, high = np.nanquantile(j50(draws, levels), [tail, 1 - tail], method="inverted_cdf")
    return {"levels": list(levels), "scores": point.tolist(), "j50": float(j50(point, levels)),
            "j50_interval": [float(low), float(high)]}


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
