"""`lgmd-sim models`: --check lists the checks passed and skipped, a broken spec is one line
with exit status 2, and no parameter's source cites an issue number."""

import re
import sys
from pathlib import Path

from lgmd_sim import cli, models
from lgmd_sim.models.check import CHECKS

BROKEN = '''
from dataclasses import dataclass

import numpy as np

from lgmd_sim.models import LGMDModel, ModelParams


@dataclass(frozen=True)
class BrokenParams(ModelParams):
    scale: float = 1.0


class Broken(LGMDModel):
    """A detector whose parameter scale has no source."""

    name = "broken"
    Params = BrokenParams
    layer_names = ()

    def allocate(self, n, height, width):
        pass

    def reset_streams(self, idx):
        pass

    def step_batch(self, grey, layers):
        return np.full(len(grey), 0.5)
'''


def test_models_check_lists_the_checks_passed_and_skipped(capsys, monkeypatch):
    assert cli.main(["models", "--check", "lgmd1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"lgmd1: passes {len(CHECKS)} checks, skips 0"
    assert [line.split(":")[0].strip() for line in out[1:]] == list(CHECKS)
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "plugins"))
    assert cli.main(["models", "--check", "lgmd_plug:NoMaps"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"lgmd_plug:NoMaps: passes {len(CHECKS) - 2} checks, skips 2"
    skipped = [line for line in out[1:] if "skipped" in line]
    assert skipped == ["  front ends: skipped (no state_maps)",
                       "  search space: skipped (no search_space)"]


def test_models_check_of_a_broken_spec_exits_2_with_one_line(tmp_path, monkeypatch, capsys):
    (tmp_path / "lgmdcheckplug.py").write_text(BROKEN)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "lgmdcheckplug", raising=False)
    try:
        assert cli.main(["models", "--check", "lgmdcheckplug:Broken"]) == 2
    finally:
        sys.modules.pop("lgmdcheckplug", None)
    assert capsys.readouterr().err == (
        "lgmd-sim models: error: lgmdcheckplug:Broken: parameters: parameter scale has no "
        "source (where its default comes from): declare it with lgmd_sim.core.params.param("
        "default, source, check=...)\n")


def test_no_source_cites_an_issue_number(capsys):
    for name in models.available():
        for pname, _default, source, _doc in models.model_class(name).Params.describe():
            assert not re.search(r"\bissue\b", source, re.I), (name, pname, source)
    assert cli.main(["models"]) == 0
    out = capsys.readouterr().out
    assert not re.search(r"\bissue\b", out, re.I)
    assert "docs/reference/models.md" in out.split("stabilize = ")[1].splitlines()[0]


def test_the_plug_in_example_passes_the_checker(examples_on_path, fresh_registries, capsys):
    assert cli.main(["models", "--check", "eta_lgmd:EtaLGMD"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "eta_lgmd:EtaLGMD: passes 10 checks, skips 0"
