"""Speed benchmarks behind ``python -m scripts.speed``: each prints figures measured in one run.

- `scripts.speed.models`: frames/s of every LGMD model on one core, streaming and
  batched, against its per-equation reference implementation.
- `scripts.speed.envs`: environment steps/s against bare renders of the same views, and
  the scaling of async vector environments.
- `scripts.speed.stabilize`: milliseconds per frame of each ego-motion front end.
- `scripts.speed.closed_loop`: the closed loop's cost over the environment alone, and
  the benchmark's scaling with workers.
- `scripts.speed.benchmark`: the benchmark's episodes against the closed-loop bench's on
  the same cells, and one entry's row.
- `scripts.speed.dataset`: dataset generation against the environment alone.
- `scripts.speed.train`: training steps/s against the bare VecEnv it trains on.

Each module's ``run(**options)`` measures and prints its tables (``python -m scripts.speed WHAT``
passes its options by name), each target with its verdict in the same run.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

from lgmd_sim.core.parallel import RunOptions

if TYPE_CHECKING:
    from lgmd_sim.core.pool import Pool

T = TypeVar("T")

#: How the timed runs run: no progress bar in the tables' output.
QUIET = RunOptions(progress=False)


def pin_to_one_core() -> str:
    """Pin this process to one core and every library to one thread; describe where."""
    import cv2
    import numba

    cv2.setNumThreads(1)
    numba.set_num_threads(1)
    if not hasattr(os, "sched_setaffinity"):
        return "not pinned (no sched_setaffinity on this platform)"
    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    return f"pinned to core {core} of {os.cpu_count()}"


def on_warm_pool(workers: int, warm: Callable[[Pool], object], run: Callable[[Pool], T]
                 ) -> tuple[T, float, float]:
    """``run(pool)`` on a pool of `workers` started and then warmed by ``warm(pool)``, as a
    long run's later jobs find their workers (imports done, environments built): its
    result, its wall seconds, and the seconds the pool's start and the warming took."""
    from lgmd_sim.core.pool import Pool

    start = time.perf_counter()
    with Pool(workers) as pool:
        warm(pool)
        begin = time.perf_counter()
        result = run(pool)
        return result, time.perf_counter() - begin, begin - start


def met(ok: bool) -> str:
    """A target's verdict, as the tables print it."""
    return "met" if ok else "not met"


def format_table(head: list[str], body: list[list[str]], markdown: bool) -> str:
    """A table with the first column left-aligned and the figures right-aligned."""
    if markdown:
        lines = ["| " + " | ".join(head) + " |",
                 "|" + "|".join(["---"] + ["---:"] * (len(head) - 1)) + "|"]
        return "\n".join(lines + ["| " + " | ".join(b) + " |" for b in body])
    widths = [max(len(row[i]) for row in [head, *body]) for i in range(len(head))]
    return "\n".join(
        "  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                  for i, (c, w) in enumerate(zip(row, widths, strict=True)))
        for row in [head, *body]
    )
