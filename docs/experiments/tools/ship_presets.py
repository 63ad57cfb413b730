"""Release a calibration's presets as shipped presets: lgmd_sim/models/calibrated.json.

    .venv/bin/python docs/experiments/tools/ship_presets.py runs/calibration-v3

Merges the calibration's DIR/calibrated.json (written by `lgmd-sim calibrate --out DIR`)
into the package's presets file in this checkout: the presets it holds replace those of
the same model and name, every other shipped preset stays, and each keeps the calibration
that made it (its command, objective, seeds, resolution, budget and figure). This is the
only way the shipped presets change; `lgmd-sim calibrate --save-presets` writes the user's
presets file (lgmd_sim.models.presets). The file moves into place complete or not at all. Afterwards
run the tests (tests/cli/test_presets.py, tests/calibration/test_calibration.py) and remake
docs/experiments/results-log.md from the same run (docs/experiments/tools/results_page.py).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from lgmd_sim.core.fileio import read_json
from lgmd_sim.models import presets

ROOT = Path(__file__).resolve().parents[3]
# This checkout's file, not presets.CALIBRATED: that is the imported package's, which may
# be an installed copy.
SHIPPED = ROOT / "lgmd_sim" / "models" / "calibrated.json"


def ship(run: Path, target: Path = SHIPPED) -> list[str]:
    """Merge `run`'s calibrated.json into `target`; the presets shipped ("model/preset")."""
    source = run / "calibrated.json"
    if not source.is_file():
        raise SystemExit(f"ship_presets.py: {run} holds no calibrated.json (run `lgmd-sim "
                         f"calibrate --out {run}` first)")
    try:
        presets.check_presets_file(source)
        presets.check_target(target)
        calibration = read_json(source)
    except (OSError, ValueError) as exc:
        raise SystemExit(f"ship_presets.py: {exc}") from exc
    presets.merge_presets(target, calibration)
    return [f"{m}/{p}" for m, entries in calibration["presets"].items() for p in entries]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", type=Path, help="the calibration (lgmd-sim calibrate --out DIR)")
    args = parser.parse_args()
    shipped = ship(args.run)
    print(f"shipped {', '.join(shipped)} into {SHIPPED.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
