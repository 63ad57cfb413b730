"""Speed benchmarks behind ``lgmd-sim speed``: each prints figures measured in one run.

- `lgmd_sim.speed.models`: frames/s of every LGMD model on one core, streaming and
  batched, against its per-equation reference implementation.
- `lgmd_sim.speed.envs`: environment steps/s against a bare render loop of the same
  scene, and the scaling of async vector environments.
- `lgmd_sim.speed.stabilize`: milliseconds per frame of each ego-motion front end.
"""

from __future__ import annotations

import platform


def cpu_name() -> str:
    """The CPU's model name, for the header of a benchmark's output."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


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
