"""scripts/training_page.py: what it computes from evaluations, on small made-up ones."""

from __future__ import annotations

import csv
import importlib
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIELDS = ["jitter", "seed", "controller", "model", "preset", "tag", "collided",
          "goal_reached", "distance_m", "frames", "progress"]


def _evaluation(folder: Path, cpu: str, ends: dict[int, str]) -> Path:
    """An evaluation folder of the oracle's episodes: seed -> its distance."""
    folder.mkdir()
    (folder / "run.json").write_text(json.dumps({"machine": {"cpu": cpu}}))
    with (folder / "episodes.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, FIELDS)
        writer.writeheader()
        for seed, distance in ends.items():
            writer.writerow({"jitter": "1.0", "seed": seed, "controller": "oracle", "model": "",
                             "preset": "", "tag": "", "collided": "False",
                             "goal_reached": "True", "distance_m": distance, "frames": "300",
                             "progress": "1.0"})
    return folder


def test_agreement_counts_the_episodes_two_evaluations_played_otherwise(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    page = importlib.import_module("training_page")
    first = _evaluation(tmp_path / "a", "Intel", {1000: "8.1", 1001: "8.2"})
    again = _evaluation(tmp_path / "b", "Intel", {1000: "8.1", 1001: "8.2", 1002: "8.0"})
    other = _evaluation(tmp_path / "c", "AMD", {1000: "8.1", 1001: "7.9"})
    assert page.agreement([first, again, other]) == [
        "- b (Intel) played 2 episodes that an earlier evaluation on the same processor "
        "played: 0 of them went otherwise (another distance or length), 0 to another end (a "
        "collision or the goal where the other had not).",
        "- c (AMD) played 2 episodes that an earlier evaluation on Intel played: 1 of them "
        "went otherwise (another distance or length), 0 to another end (a collision or the "
        "goal where the other had not)."]


def _choice(folder: Path, first_seed: int, ends: dict[str, list[tuple[str, str]]]) -> Path:
    """A choice folder: per policy tag, its episodes' (collided, goal_reached) at jitter 1
    and 2 alike, on seeds from `first_seed`."""
    folder.mkdir()
    n = len(next(iter(ends.values())))
    (folder / "run.json").write_text(json.dumps({"config": {"seeds": [first_seed, n]},
                                                 "command": "lgmd-sim eval a b"}))
    with (folder / "episodes.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, FIELDS)
        writer.writeheader()
        for tag, episodes in ends.items():
            for jitter in ("1.0", "2.0"):
                for k, (collided, reached) in enumerate(episodes):
                    writer.writerow({"jitter": jitter, "seed": first_seed + k,
                                     "controller": "policy", "model": "", "preset": "",
                                     "tag": tag, "collided": collided, "goal_reached": reached,
                                     "distance_m": "8", "frames": "300", "progress": "1.0"})
    return folder


def test_choice_ships_the_best_score_on_validation_seeds_only(tmp_path, monkeypatch):
    import pytest

    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    page = importlib.import_module("training_page")
    ends = {"a": [("False", "True"), ("True", "False")],  # 50% / 50%: score 0
            "b": [("False", "True"), ("False", "False")]}  # 50% / 0%: score 0.5
    run = _choice(tmp_path / "choice", 900, ends)
    lines = page.choice([run], "b")
    assert "policy: b has the highest score" in lines[0] and "0.50), so it was shipped" in lines[0]
    assert lines[-2:] == ["| policy: b | 50 / 0 | 50 / 0 | 0.50 |",
                          "| policy: a | 50 / 50 | 50 / 50 | 0.00 |"]
    assert page.choice([run], "a")[0].endswith("but the shipped one is a.")
    with pytest.raises(SystemExit, match="a choice runs validation seeds"):
        page.choice([_choice(tmp_path / "held-out", 999, ends)], "b")  # 999 and 1000
    # a later candidate, evaluated apart on the same seeds, joins the choice
    later = _choice(tmp_path / "later", 900, {"c": [("False", "True"), ("False", "True")]})
    lines = page.choice([run, later], "c")
    assert "the 3 candidates below" in lines[0] and "policy: c has the highest" in lines[0]
    assert lines[-3] == "| policy: c | 100 / 0 | 100 / 0 | 1.00 |"
    with pytest.raises(SystemExit, match="played other seeds"):
        page.choice([run, _choice(tmp_path / "other", 910, ends)], "b")
