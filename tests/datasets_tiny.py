"""The tiny dataset the data tests generate (tests/data/, tests/cli/test_dataset_command.py),
as a configuration and as a command line, and what of a dataset must be byte-identical."""

from __future__ import annotations

from pathlib import Path

from lgmd_sim.data import layout
from lgmd_sim.data.generate import GenerateConfig

#: Two scenarios at two jitter levels, two episodes each, at 32 x 48 with noise.
CONFIG = GenerateConfig(("PassBy", "HandheldApproach"), (0.0, 1.0), 2, (32, 48),
                        models=("feedback",), noise=("gaussian:0.005", "saltpepper:0.01"))
#: The same, as a command line (tests/cli/test_dataset_command.py runs it).
ARGS = ["--scenarios", "PassBy,HandheldApproach", "--jitter", "0,1", "--episodes", "2",
        "--resolution", "32x48", "--models", "feedback", "--noise",
        "gaussian:0.005,saltpepper:0.01"]


def tree(root: Path) -> dict[str, bytes]:
    """Every file of a dataset but the run log: what must be byte-identical."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.relative_to(root).as_posix() != layout.RUNS}
