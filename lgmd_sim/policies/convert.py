"""Convert policy folders written before policies carried no pickle (a stable-baselines3
``policy.zip`` beside ``policy.json``) into ``policy.npz`` and ``policy.json``:

    python -m lgmd_sim.policies.convert DIR [DIR ...]

The zip is unpickled, which runs whatever its author put in it: convert only folders you
made or that come from someone you trust (`lgmd_sim.policies.folder.convert`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from lgmd_sim.core.extras import MissingExtra
from lgmd_sim.policies.folder import convert

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m lgmd_sim.policies.convert",
                                     description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folders", nargs="+", type=Path, metavar="DIR",
                        help="policy folders holding policy.zip and policy.json")
    for folder in parser.parse_args(argv).folders:
        try:
            print(f"converted {convert(folder)}: policy.zip is no longer read; delete it "
                  "once the policy acts as before")
        except (ValueError, OSError, MissingExtra) as exc:
            parser.exit(2, f"{parser.prog}: error: {exc}\n")


if __name__ == "__main__":
    main()
