"""`lgmd-sim train`: its arguments, and the `TrainConfig` made from them.

Options default to None here so that ``--resume`` can tell the ones given from the ones
recorded: a resumed run takes the recorded ones, and only `RESUMABLE` ones may be given
anew; `TrainConfig`'s defaults are the ones the help text names. The research settings
are not options but keys of a --config TOML file (`lgmd_sim.core.configfile.read_toml`),
each declared once, with its meaning and default, as a field of `TrainConfig`; the
options given override the file's keys, which override the recorded run's or the
defaults.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
from pathlib import Path
from typing import Any

from lgmd_sim.cli.args import add_config_file, advanced, option, print_result, resolution
from lgmd_sim.core.extras import install_command
from lgmd_sim.core.params import FieldError


def add(sub: argparse._SubParsersAction) -> None:
    from lgmd_sim.training.config import TrainConfig

    p = sub.add_parser(
        "train", help="train an avoidance policy with stable-baselines3 (needs the rl extra)",
        description="Train a policy that reads an LGMD model's signals (--obs features: its "
        "potential history, alarm and S-layer grid, with the proprioception and goal; an MLP), "
        "small stacked grey frames (--obs pixels; a CNN) or the ground truth the Oracle "
        "reads (--obs privileged: the threat's distance, bearing, time to collision and "
        "closing speed; an MLP, the upper bound for the others) to drive to the goal without "
        "colliding. Vectorised environments, observation normalisation, validation on fixed "
        "held-out seeds, checkpoints, TensorBoard logs; writes DIR/policy.npz and "
        "policy.json (a policy for lgmd-sim bench closed-loop --policies), DIR/best/, "
        "DIR/learning_curve.png, DIR/summary.md and DIR/run.json. The reward is the "
        "environment's (lgmd-sim envs NAME) unless --config shapes it. Needs the rl extra, "
        f"stable-baselines3 and PyTorch (install it {install_command('rl')}).",
    )
    option(p, TrainConfig, "algo")
    option(p, TrainConfig, "env", metavar="ID")
    option(p, TrainConfig, "obs")
    option(p, TrainConfig, "model")
    option(p, TrainConfig, "preset", shown="")
    option(p, TrainConfig, "steps", type=int)
    option(p, TrainConfig, "envs", type=int, metavar="K")
    option(p, TrainConfig, "seed", type=int)
    add_config_file(p, "the research ones (the S-layer grid, validation, reward shaping, a "
                    "curriculum, a teacher and DAgger; docs/guides/training.md explains them)",
                    TrainConfig)
    p.add_argument("--out", metavar="DIR", help="output folder, new or empty (default "
                   "./train-ALGO-OBS)")
    p.add_argument("--resume", metavar="DIR", help="continue the run in DIR from its last "
                   "checkpoint, up to --steps in all")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    more = advanced(p, "the frames and jitter it trains on, and the algorithm's "
                    "hyperparameters")
    option(more, TrainConfig, "resolution", type=resolution)
    option(more, TrainConfig, "jitter", type=float)
    more.add_argument("--hp", action="append", metavar="KEY=VALUE",
                      help="override a hyperparameter of the algorithm (repeatable), e.g. "
                      "--hp n_steps=512 --hp learning_rate=1e-4; with --resume, added to the "
                      "run's (not policy_kwargs), e.g. --hp target_kl=0.02 for gentler "
                      "fine-tuning")


def config_from_args(args: argparse.Namespace) -> Any:
    """The `TrainConfig` of ``train``'s arguments: the options given over the keys of the
    --config file, over the run's recorded configuration when resuming (where only
    `RESUMABLE` ones may differ), else over the defaults.

    Raises:
        ValueError: a --config file that cannot be read, is not TOML or holds another key;
            a value TrainConfig refuses; a resumed run's key changed that may not (one line,
            naming the file where its key is at fault).
    """
    from lgmd_sim.core.configfile import read_toml
    from lgmd_sim.training.config import KEYS_LISTED
    from lgmd_sim.training.run import RESUMABLE, TrainConfig, resumable

    names = [f.name for f in dataclasses.fields(TrainConfig)]
    options = {k: getattr(args, k) for k in names if getattr(args, k, None) is not None}
    keys = read_toml(args.config, TrainConfig, listed=KEYS_LISTED) if args.config else {}
    from_file = {k: v for k, v in keys.items() if k not in options}
    given = {**from_file, **options}

    def named(key: str, value: Any) -> str:
        if key in from_file:
            return f"{args.config}: {key} = {json.dumps(value, default=str)}"
        return f"--{key.replace('_', '-')} {value}"

    if args.resume is not None:
        recorded = resumable(args.resume)["config"]
        for key, value in given.items():
            # as JSON records it (a TOML date, which no key takes, as its text)
            if key not in RESUMABLE and json.loads(json.dumps(value, default=str)) != recorded[key]:
                *others, last = [f"--{k.replace('_', '-')}" if hasattr(args, k)
                                 else f"the key {k}" for k in RESUMABLE]
                changeable = f"{', '.join(others)} and {last}"
                raise ValueError(f"{named(key, value)} differs from the run being resumed "
                                 f"({recorded[key]}); only {changeable} may change")
        hp = given.get("hp")
        if isinstance(hp, list | tuple) and all(isinstance(item, str) for item in hp):
            shaped = [item for item in hp if item.partition("=")[0] == "policy_kwargs"]
            if shaped:
                raise ValueError(f"{named('hp', shaped[0])}: a resumed run keeps its network "
                                 "(policy_kwargs); only other hyperparameters may be added")
            given["hp"] = [*recorded["hp"], *hp]  # added to the run's: a later one wins
        given = {**{k: recorded[k] for k in names}, **given}
    try:
        return TrainConfig(**given)
    except ValueError as exc:
        # TrainConfig names the field at fault; where the file gave it, the file too
        from_the_file = (exc.field in from_file if isinstance(exc, FieldError)
                         else any(_mentions(str(exc), key) for key in from_file))
        if from_the_file:
            raise ValueError(f"{args.config}: {exc}") from None
        raise


def _mentions(text: str, key: str) -> bool:
    """Whether a message names `key`, as a key or as its option."""
    option = "--" + key.replace("_", "-")
    return re.search(rf"(?<![\w-])(?:{re.escape(key)}|{re.escape(option)})(?![\w-])",
                     text) is not None


def run(args: argparse.Namespace) -> int:
    from lgmd_sim.training.run import train
    from lgmd_sim.training.summary import summary_markdown

    if args.resume and args.out is not None and Path(args.out) != Path(args.resume):
        raise ValueError("--out and --resume name different folders: --resume continues "
                         "the run in its own folder")
    config = config_from_args(args)
    out = args.resume or args.out or f"train-{config.algo}-{config.obs}"
    result = train(config, out, resume=args.resume is not None,
                   progress=False if args.no_progress else None, command=args.command_line)
    return print_result(summary_markdown(result.path), result)
