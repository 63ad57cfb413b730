"""docs/experiments/tools/training_page.py: what it computes from evaluations, on small made-up
ones, and where it writes (docs/experiments/training-runs.md, the research log)."""

from __future__ import annotations

import csv
import importlib
import json
import re
from pathlib import Path

import pytest

# The research log's tools (docs/experiments/tools/): the slow tier, out of the edit loop.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[4]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts
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
    monkeypatch.syspath_prepend(str(TOOLS))
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

    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    ends = {"a": [("False", "True"), ("True", "False")],  # 50% / 50%: score 0
            "b": [("False", "True"), ("False", "False")]}  # 50% / 0%: score 0.5
    run = _choice(tmp_path / "choice", 900, ends)
    lines = page.choice([run], "b", "shipped")
    assert "policy: b has the highest score" in lines[0] and "0.50), so it was shipped" in lines[0]
    assert lines[-2:] == ["| policy: b | 50 / 0 | 50 / 0 | 0.50 |",
                          "| policy: a | 50 / 50 | 50 / 50 | 0.00 |"]
    assert page.choice([run], "a", "shipped")[0].endswith("but the shipped one is a.")
    with pytest.raises(SystemExit, match="a choice runs validation seeds"):
        page.choice([_choice(tmp_path / "held-out", 999, ends)], "b", "shipped")  # 999, 1000
    # a later candidate, evaluated apart on the same seeds, joins the choice
    later = _choice(tmp_path / "later", 900, {"c": [("False", "True"), ("False", "True")]})
    lines = page.choice([run, later], "c", "shipped")
    assert "the 3 candidates below" in lines[0] and "policy: c has the highest" in lines[0]
    assert lines[-3] == "| policy: c | 100 / 0 | 100 / 0 | 1.00 |"
    with pytest.raises(SystemExit, match="played other seeds"):
        page.choice([run, _choice(tmp_path / "other", 910, ends)], "b", "shipped")


def test_a_later_candidate_replaces_the_shipped_policy_only_beyond_the_paired_interval(
        tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    even = [("False", "True"), ("True", "False")] * 2  # score 0
    first = _choice(tmp_path / "choice", 900, {"a": even})
    # the shipped policy played again beside a later candidate, one episode in four better
    later = _choice(tmp_path / "later", 900, {
        "shipped": even, "c": [("False", "True"), ("False", "True"), ("True", "False"),
                               ("False", "True")]})
    verdict = page.choice([first, later], "a", "shipped")[0]
    assert "policy: c has the highest score" in verdict
    assert verdict.endswith(
        "but a stays shipped as shipped: policy: c against policy: shipped, paired on the "
        "seeds of later: +0.50 [-1.00, +2.00], within its 95% interval.")


def _cell(reached: int, collided: int, n: int = 30) -> dict[str, float]:
    return {"n": n, "reached": reached, "collided": collided, "distance": 8.0, "progress": 0.8}


def test_targets_state_issue_17_s_once_and_give_each_policy_one_verdict(monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    best = {1.0: "reactive: lgmd1/robot-image", 2.0: "reactive: lgmd1/robot-image"}
    cells = {(1.0, best[1.0]): _cell(13, 16), (2.0, best[2.0]): _cell(10, 20),
             # meets 60% / 10% at jitter 1 and 50% at jitter 2, and beats ReactiveAvoid
             (1.0, "policy: good"): _cell(20, 3), (2.0, "policy: good"): _cell(15, 12),
             # 63% at jitter 1 and 50% at jitter 2, but 37% collisions at jitter 1: not met
             (1.0, "policy: split"): _cell(19, 11), (2.0, "policy: split"): _cell(15, 14),
             (1.0, "policy: truth"): _cell(22, 0), (2.0, "policy: truth"): _cell(12, 0),
             (1.0, "policy: cnn"): _cell(14, 15), (2.0, "policy: cnn"): _cell(17, 13)}
    lines = page.targets(cells, best, {"good": "features", "split": "features",
                                       "truth": "privileged", "cnn": "pixels"})
    text = "\n".join(lines)
    assert lines[0].startswith("Issue 17 (policies that reach the goal) set these targets")
    assert text.count("60% successes or more with 10% collisions or fewer at jitter 1") == 1
    rows = {line.split(" | ")[0][2:]: line for line in lines if line.startswith("| ")
            and " | " in line and not line.startswith("| policy")}
    assert rows["good"].endswith("| 67 / 10 | 50 / 40 | none | met |")
    assert rows["split"].endswith("| collisions over 10% at jitter 1 | not met |")
    assert rows["truth"].endswith("| successes under 75% at jitter 1 | not met |")  # 22 / 30
    assert rows["cnn"].endswith("| - | none set for pixels |")
    # each policy has one verdict: "met" or "not met" once, in its own row only
    for name in ("good", "split", "truth"):
        assert sum(f"| {name} |" in line for line in lines) == 1
    assert "No policy on" not in text
    # a student that ties ReactiveAvoid's successes does not beat it
    cells[(2.0, "policy: good")] = _cell(10, 0)
    row = next(r for r in page.targets(cells, best, {"good": "features"}) if "| good |" in r)
    assert "successes under 50% at jitter 2; ReactiveAvoid not beaten at jitter 2" in row
    assert "- No policy on `--obs privileged` is in this evaluation." in page.targets(
        cells, best, {"good": "features"})


def test_reading_gives_the_numbers_and_leaves_the_verdict_to_targets(monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    best = {1.0: "reactive: lgmd1/robot-image"}
    cells = {(1.0, best[1.0]): _cell(13, 16), (1.0, "policy: a"): _cell(20, 3)}
    assert page.reading(cells, best, ["a"], 1.0) == [
        "- jitter 1 (trained), a: 10% collisions, 67% successes, 8.0 m travelled; "
        "ReactiveAvoid with lgmd1/robot-image: 53% and 43%."]


def test_the_page_is_the_research_log_s_and_its_figures_resolve_from_it(tmp_path,
                                                                       monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    assert page.PAGE == ROOT / "docs" / "experiments" / "training-runs.md"
    figure = tmp_path / "trajectories.png"
    figure.write_bytes(b"png")
    figures: dict[Path, Path | list[Path]] = {}
    link = page._copy(figure, "trajectories.png", figures)
    assert link == "../training/trajectories.png"
    assert (page.PAGE.parent / link).resolve() == page.FIGURES / "trajectories.png"
    assert figures == {page.FIGURES / "trajectories.png": figure}


def test_the_runs_learning_curves_are_one_figure_their_pixels_one_above_the_other(
        tmp_path, monkeypatch):
    """The page shows every run's learning curve in one file of the repository: the runs'
    own PNGs, in the order of --train, stacked as they are (a narrower one padded white)."""
    import cv2
    import numpy as np

    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    rng = np.random.default_rng(0)
    curves = []
    for name, (height, width) in (("a", (3, 5)), ("b", (2, 4))):
        (tmp_path / name).mkdir()
        curves.append(tmp_path / name / "learning_curve.png")
        cv2.imwrite(str(curves[-1]), rng.integers(0, 256, (height, width, 3), np.uint8))
    figures: dict[Path, Path | list[Path]] = {}
    link = page._stack(curves, "learning_curves.png", figures)
    assert link == "../training/learning_curves.png"
    assert figures == {page.FIGURES / "learning_curves.png": curves}
    out = tmp_path / "written"  # as write_files gives it: no suffix
    page._copier(curves)(out)
    sheet = cv2.imread(str(out), cv2.IMREAD_UNCHANGED)
    a, b = (cv2.imread(str(c)) for c in curves)
    assert sheet.shape == (5, 5, 3)
    assert np.array_equal(sheet[:3], a) and np.array_equal(sheet[3:, :4], b)
    assert (sheet[3:, 4] == 255).all()
    with pytest.raises(SystemExit, match="missing"):
        page._stack([tmp_path / "c" / "learning_curve.png"], "learning_curves.png", figures)


def test_each_shipped_policy_s_policy_md_names_the_page_of_all_its_rows(monkeypatch):
    """ship_policy.py writes the page's path into POLICY.md (from training_page.PAGE):
    a shipped one names the page that holds its evaluation's rows today."""
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    from lgmd_sim import policies

    named = f"(all rows: {page.PAGE.relative_to(ROOT).as_posix()})"
    for name in policies.available():
        assert named in (policies.path(name) / "POLICY.md").read_text(), name


def test_the_log_says_met_only_in_its_targets_table_once_per_policy(monkeypatch):
    """The issue found a policy "met" on one line and "not met" on another: the page
    states its targets once, and gives each policy one verdict, in one table."""
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    text = page.PAGE.read_text()
    targets = text[text.index("### Targets\n"):]
    targets = targets[:targets.find("\n#")] if "\n#" in targets else targets
    verdicts = [line for line in text.splitlines() if re.search(r"\bmet\b", line)]
    assert verdicts and all(line in targets and line.startswith("| ") for line in verdicts)
    names = [line.split(" | ")[0] for line in verdicts]
    assert len(names) == len(set(names)), "a policy with two verdicts"
    assert targets.startswith("### Targets\n\nIssue 17")


def test_a_recorded_command_is_shown_as_today_s_where_one_says_the_same(monkeypatch):
    """`lgmd-sim eval POLICY ...` is `bench closed-loop --policies POLICY,...` with the same
    options, `--ray` is `--workers ray` (its address in RAY_ADDRESS); a command that set an
    option now a key of --config FILE.toml stays as it was run, in a text block."""
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("training_page")
    assert page.today("lgmd-sim eval --out runs/e --no-progress") == (
        "lgmd-sim bench closed-loop --policies shipped --out runs/e --no-progress")
    assert page.today("lgmd-sim eval a b/best --controllers none --seeds 5 --ray local") == (
        "lgmd-sim bench closed-loop --policies a,b/best --controllers none --seeds 5 "
        "--workers ray")
    assert page.today("lgmd-sim bench closed-loop --ray auto --workers 2") == (
        "RAY_ADDRESS=auto lgmd-sim bench closed-loop --workers ray")
    assert page.today("lgmd-sim eval a --top-views 2") is None
    assert page.command_block(["lgmd-sim eval a"]) == [
        "```bash", "lgmd-sim bench closed-loop --policies a", "```"]
    text = page.command_block(["lgmd-sim eval a", "lgmd-sim bench closed-loop --sides eyes"])
    assert text[:4] == ["```text", "lgmd-sim eval a", "lgmd-sim bench closed-loop --sides eyes",
                        "```"]
