"""docs/experiments/tools/imitation_gap.py: on labels where the detector's alarm comes just before
each of the Oracle's manoeuvres and the proprioception is noise, the detector's features predict the
manoeuvre and the proprioception does not."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

# The research log's tools (docs/experiments/tools/): the slow tier, out of the edit loop.
pytestmark = pytest.mark.slow

pytest.importorskip("torch")
ROOT = Path(__file__).resolve().parents[4]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts


def _run(folder: Path, envs: int = 2, rounds: int = 2, steps: int = 1200) -> Path:
    """A DAgger run folder of `rounds` rounds: in every stream a 20-step manoeuvre starts
    at each 60th step, the alarm on for the 6 steps before it (the script's WITHIN) and at
    its start."""
    from lgmd_sim.controllers.avoid import OracleParams

    p, rng = OracleParams(), np.random.default_rng(0)
    per_stream = steps // rounds // envs
    t = np.tile(np.arange(per_stream), rounds)  # each round's streams start afresh
    phase = t % 60
    turning, alarm = (phase >= 30) & (phase < 50), (phase >= 24) & (phase <= 30)
    n = len(t) * envs
    actions = np.tile(np.array([p.cruise, 0.3], np.float32), (n, 1))
    actions[np.repeat(turning, envs)] = [p.avoid_speed, p.avoid_turn]
    on = np.repeat(alarm, envs)[:, None].astype(np.float32)
    arrays = {"obs.proprio": rng.normal(size=(n, 11)).astype(np.float32),
              "obs.goal": rng.normal(size=(n, 3)).astype(np.float32),
              "obs.lgmd_potential": np.repeat(on, 8, 1), "obs.lgmd_alarm": on,
              "obs.lgmd_grid": np.repeat(on, 3, 1), "actions": actions}
    (folder / "checkpoints").mkdir(parents=True)
    np.savez(folder / "checkpoints" / "dagger.npz", **arrays)
    config = {"obs": "features", "teacher": "oracle", "model": "lgmd1",
              "preset": "robot-image", "envs": envs, "imitation_steps": steps,
              "dagger_rounds": rounds}
    (folder / "run.json").write_text(json.dumps({"config": config}))
    return folder


def test_the_detector_that_foretells_the_manoeuvre_is_measured_so(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    gap_script = importlib.import_module("imitation_gap")
    g = gap_script.gap(_run(tmp_path / "run"))
    assert g.onsets == 2 * 2 * 5  # 5 manoeuvres per stream and round
    assert g.alarm_at_onsets == 1.0 and g.alarm_otherwise < 0.2  # its 6 steps before
    assert g.auc["detector's features"][0] > 0.9
    assert 0.3 < g.auc["proprioception and goal"][0] < 0.7  # noise: chance
    assert "| run | lgmd1/robot-image |" in "\n".join(gap_script.table([g]))


def test_a_run_without_the_oracle_as_teacher_is_refused(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    gap_script = importlib.import_module("imitation_gap")
    folder = _run(tmp_path / "run")
    record = json.loads((folder / "run.json").read_text())
    record["config"]["teacher"] = None
    (folder / "run.json").write_text(json.dumps(record))
    with pytest.raises(SystemExit, match='teacher = "oracle"'):
        gap_script.gap(folder)
