"""Release a training run's final (or best) policy as a shipped policy:
lgmd_sim/policies/NAME/.

    .venv/bin/python docs/experiments/tools/ship_policy.py runs/train/RUN --eval runs/eval \
        --name NAME

Copies the run's policy.npz and policy.json (with --best, those of RUN/best, its best
validation; a policy folder: arrays and JSON, no pickle) into the package and writes
POLICY.md beside them: the command that started the training, how to train it again (a
`lgmd-sim train --config` file of its settings), the run's summary (its
sessions and validation), and that policy's rows of the evaluation's table (the rows of
docs/experiments/training-runs.md, which docs/experiments/tools/training_page.py writes from the
same runs). NAME (--name) defaults to the policy `lgmd-sim bench closed-loop --policies
shipped` and the "policy" controller use (lgmd_sim.policies.DEFAULT), so releasing a run
without --name replaces it. The three files move into place together
(lgmd_sim.core.fileio.write_files): a failed release leaves the shipped policy as it was.
Run the tests afterwards (tests/training/test_training.py checks the shipped policy acts in its
environment; tests/cli/test_packaging.py that it travels in the wheel).
"""

from __future__ import annotations

import argparse
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from training_page import PAGE, ROOT, run_summary, table

from lgmd_sim.core.configfile import config_toml
from lgmd_sim.core.fileio import write_files
from lgmd_sim.policies import DEFAULT
from lgmd_sim.policies.folder import CONFIG_FILE, MODEL_FILE, name_of
from lgmd_sim.training.config import TrainConfig

POLICIES = ROOT / "lgmd_sim" / "policies"


def policy_md(run: Path, eval_run: Path, name: str, best: bool = False) -> str:
    """POLICY.md of `run`'s final (or `best`) policy shipped as `name`: the run's first
    command, its summary, and the policy's rows of the evaluation's table, renamed to
    `name`."""
    rows, _, _ = table([eval_run], [])  # the policy's own rows do not depend on the benches
    tag = f"policy: {name_of(run / 'best') if best else run.name}"
    mine = [line.replace(tag, f"policy: {name}") for line in rows[2:] if f"| {tag} |" in line]
    if not mine:
        raise SystemExit(f"ship_policy.py: {eval_run} holds no rows of {tag} (its "
                         f"controllers); evaluate it with `lgmd-sim bench closed-loop "
                         f"--policies {run / 'best' if best else run}` first")
    record = json.loads((run / "run.json").read_text())
    command = record["sessions"][0]["command"]
    which = "The best policy by validation (`best/`)" if best else "The final policy"
    return (f"# {name}\n\n{which} of the training run started by (as its run recorded "
            f"it)\n\n```text\n{command}\n```\n\n{retrain(record['config'], name)}\n\n"
            f"{run_summary(run)}\n\n"
            "Evaluated on held-out seeds by `lgmd-sim bench closed-loop --policies` (all rows: "
            f"{PAGE.relative_to(ROOT).as_posix()}):\n\n"
            + "\n".join([*rows[:2], *mine]) + "\n")


def retrain(config: dict[str, Any], name: str) -> str:
    """How to train `name` again (Markdown): the run's recorded configuration, where it is
    not the defaults, as a --config file, and the command that reads it; the command that
    started the run may name options lgmd-sim no longer has."""
    return (f"To train it again, save its settings (those that are not the defaults) as "
            f"`{name}.toml`:\n\n```toml\n{config_toml(TrainConfig, config)}```\n\n```bash\n"
            f"lgmd-sim train --config {name}.toml --out runs/train/{name}\n```")


def ship(run: Path, eval_run: Path, name: str = DEFAULT, best: bool = False) -> Path:
    """Write lgmd_sim/policies/`name`/ from `run`'s final (or `best`) policy and its
    evaluation; the folder."""
    source = run / "best" if best else run
    missing = [str(f.relative_to(run)) for f in (source / MODEL_FILE, source / CONFIG_FILE,
                                                 run / "run.json", run / "summary.md")
               if not f.is_file()]
    if missing:
        raise SystemExit(f"ship_policy.py: {run} is not a finished training run (no "
                         f"{', '.join(missing)})")
    folder = POLICIES / name
    text = policy_md(run, eval_run, name, best)
    write_files({folder / MODEL_FILE: _copier(source / MODEL_FILE),
                 folder / CONFIG_FILE: _copier(source / CONFIG_FILE),
                 folder / "POLICY.md": lambda tmp: tmp.write_text(text)})
    return folder


def _copier(source: Path) -> Callable[[Path], None]:
    return lambda tmp: shutil.copyfile(source, tmp)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", type=Path, help="the training run (lgmd-sim train --out DIR)")
    parser.add_argument("--eval", type=Path, required=True,
                        help="the run of `lgmd-sim bench closed-loop --policies` that "
                        "evaluated it (its rows go into POLICY.md)")
    parser.add_argument("--name", default=DEFAULT,
                        help=f"the shipped policy's name (default {DEFAULT}, the one "
                        "`--policies shipped` uses)")
    parser.add_argument("--best", action="store_true",
                        help="the run's best policy by validation (RUN/best), not its final")
    args = parser.parse_args()
    print(f"shipped {ship(args.run, args.eval, args.name, args.best).relative_to(ROOT)}")


if __name__ == "__main__":
    main()
