"""Trained policies: the policy folder on disk, what a policy observes, and the policies
that ship with lgmd-sim.

- `lgmd_sim.policies.folder`: a policy folder (the network's weights as plain arrays, its
  architecture, `PolicyConfig` and the frozen observation normalisation: data, no
  pickle), `save` and `load`, as `lgmd-sim train` writes them;
- `lgmd_sim.policies.config`: `PolicyConfig` (the environment and observation pipeline
  a policy was trained with) and `Normalizer` (its frozen observation normalisation);
- `lgmd_sim.policies.convert`: ``python -m lgmd_sim.policies.convert DIR`` rewrites a
  trusted folder of the earlier format (stable-baselines3's pickled ``policy.zip``);
- `lgmd_sim.policies.observe`: the observation pipeline of a `PolicyConfig`, shared by
  the `lgmd_sim.controllers.Policy` controller and training;
- the shipped policies: each a policy folder beside this file, with a ``POLICY.md`` (the
  command that trained it and its evaluation table).

>>> from lgmd_sim import policies
>>> policies.available(), policies.path(policies.DEFAULT)

``lgmd-sim bench closed-loop --policies shipped`` evaluates `DEFAULT`; ``--controllers
policy`` in ``lgmd-sim bench closed-loop`` drives with it.
"""

from __future__ import annotations

from pathlib import Path

from lgmd_sim.policies.config import Normalizer, PolicyConfig
from lgmd_sim.policies.folder import LoadedPolicy, load, load_config, name_of, resolve, save

__all__ = ["DEFAULT", "EVAL_SEEDS", "EVAL_TOP_VIEWS", "LoadedPolicy", "Normalizer",
           "PolicyConfig", "available", "load", "load_config", "name_of", "path", "resolve", "save"]

#: The shipped policy that `--policies shipped` (and the "policy" controller) use by default.
DEFAULT = "feedback-student"
#: Episodes per cell of `bench closed-loop --policies` by default: those of the evaluation
#: that a shipped policy's POLICY.md and docs/guides/training.md quote, so that the defaults
#: reproduce its rows.
EVAL_SEEDS = 30
#: Seeds of it drawn from above in its trajectories figure: the policies beside the Oracle.
EVAL_TOP_VIEWS = 3
_HERE = Path(__file__).resolve().parent


def available() -> list[str]:
    """The names of the shipped policies."""
    return sorted(p.parent.name for p in _HERE.glob("*/policy.json"))


def path(name: str) -> Path:
    """The folder of shipped policy `name`."""
    if name not in available():
        raise ValueError(f"no shipped policy {name!r}; shipped: {', '.join(available())}")
    return _HERE / name
