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
