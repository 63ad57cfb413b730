"""An episode's fingerprint: a hash of everything it went through, step by step, so that two
runs of one episode (on two machines, in two numeric modes) can be told identical to the
bit, or found to part at a step.

Each step adds the observation's arrays (the frame the detector saw among them), the
carrier's position, the action and the detector's potential to a running SHA-256; every
`EVERY` steps the digest so far joins a chain. Two episodes are identical where their last
digests are; where not, the first link of their chains that differs says within which
`EVERY` steps they parted.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["EVERY", "Fingerprint", "combined", "first_difference"]

#: Steps between the chain's links (an episode of the benchmark: 100 to 900 steps).
EVERY = 25
#: Hex digits of a link: enough to tell two trajectories apart, small in a record.
_LINK = 16


class Fingerprint:
    """The running hash of one episode (`add` each step, then `to_json`)."""

    def __init__(self) -> None:
        self._hash = hashlib.sha256()
        self._steps = 0
        self._chain: list[str] = []

    def add(self, obs: Mapping[str, Any] | np.ndarray, info: Mapping[str, Any],
            action: np.ndarray | None, potential: float | None = None) -> None:
        """One step: its observation, the carrier's position, the action taken (None on
        the last step) and the potential of the detector that chose it (None: none), which
        parts first where a detector's arithmetic does."""
        arrays = obs.items() if isinstance(obs, Mapping) else [("obs", obs)]
        for key, value in sorted(arrays, key=lambda kv: kv[0]):
            value = np.ascontiguousarray(value)
            self._hash.update(f"{key}:{value.dtype.str}:{value.shape}".encode())
            self._hash.update(value.tobytes())
        self._hash.update(np.asarray(info["carrier_pos"], np.float64).tobytes())
        if action is not None:
            self._hash.update(np.asarray(action, np.float32).tobytes())
        if potential is not None:
            self._hash.update(np.float64(potential).tobytes())
        self._steps += 1
        if self._steps % EVERY == 0:
            self._chain.append(self._hash.hexdigest()[:_LINK])

    def to_json(self) -> dict[str, Any]:
        """The record's field: the steps, the chain (a link every `EVERY` steps) and the
        digest of the whole episode."""
        return {"steps": self._steps, "every": EVERY, "chain": list(self._chain),
                "sha256": self._hash.hexdigest()}


def first_difference(a: Mapping[str, Any], b: Mapping[str, Any]) -> int | None:
    """The first step at which two fingerprints may part (the start of the first chain
    link that differs, or the end of the shorter one), None where they are identical."""
    if a["sha256"] == b["sha256"] and a["steps"] == b["steps"]:
        return None
    for i, (x, y) in enumerate(zip(a["chain"], b["chain"], strict=False)):
        if x != y:
            return i * a["every"]
    return min(len(a["chain"]), len(b["chain"])) * a["every"]


def combined(fingerprints: Sequence[str]) -> str:
    """One digest over episodes' digests (in the order given: the records' keys')."""
    return hashlib.sha256("\n".join(fingerprints).encode()).hexdigest()
