"""The benchmark: its protocol read and checked, the scores on hand-made episodes, the
paired comparison on made-up ones, and the command end to end on a tiny protocol (the
same result twice, resumed after an interruption, merged into a leaderboard of one
protocol only)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.benchmark import entries, protocol, scores
from lgmd_sim.models.presets import carrying_presets, user_presets_from

from protocols import tiny_protocol

SHIPPED = protocol.PROTOCOLS["v1"].read_text()
ROOT = Path(__file__).resolve().parents[2]


# --- the protocol ------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["v1", "v2"])
def test_the_shipped_protocols_read_as_they_say(name):
    p = protocol.load(name)
    assert (p.version, p.resolution, p.goal.scenario, p.arena.scenario) == (
        int(name[1]), "rl", "RoughTerrainObstacles", "ArenaRoam")
    assert p.goal.seeds[0] == 20000 and len(p.goal.seeds) == p.goal.episodes
    assert len(p.arena.reference_distance_m) == len(p.arena.jitter)
    # disjoint from every seed a calibration, training, validation or evaluation uses
    tracks = (p.goal, p.arena, p.detection, *([p.stimuli] if p.stimuli else []))
    for track in tracks:
        assert min(track.seeds) > 7103
    assert protocol.load().name == protocol.CURRENT == "v2"


@pytest.mark.parametrize(("change", "message"), [
    ({"horizon": "colour = 2"}, "unknown key colour"),
    ({"cruise": ""}, "no key cruise"),
    ({"episodes": 'episodes = "many"'}, "goal.episodes must be an int"),
    ({"non_approach": 'non_approach = ["Receding", "Wobble"]'}, "stimulus 'Wobble'"),
    ({"scenario": 'scenario = "Nowhere"'}, "goal.scenario 'Nowhere' is not a scenario"),
    ({"jitter": "jitter = []"}, "goal.jitter must be a non-empty array"),
    ({"reference_distance_m": "reference_distance_m = [1.0, 2.0]"},
     "reference_distance_m must hold a distance > 0 per jitter level"),
    # found only after the closed-loop tracks ran, or never (issue 49, item 7)
    ({"approaching": 'approaching = ["Looming", "Looming"]'},
     "detection.approaching: stimulus 'Looming' is in detection.approaching already"),
    ({"non_approach": 'non_approach = ["Receding", "Looming"]'},
     "detection.non_approach: stimulus 'Looming' is in detection.approaching already"),
    ({"bootstrap_seed": "bootstrap_seed = -1"}, "bootstrap_seed must be an integer >= 0"),
    ({"bootstrap": "bootstrap = 1000000000000"}, "bootstrap must be at most 100,000"),
    ({"bootstrap": "bootstrap = 20000000"}, "bootstrap must be at most 100,000"),
    ({"budget": "budget = 0"}, "calibration.budget must be an integer >= 1, got 0"),
    ({"heldout_seed": "heldout_seed = 3"}, "calibration: the search seeds"),
    # the protocol's keys, not the CLI's options (--jitter, --resolution)
    ({"jitter": "jitter = [1.0, 1.0]"}, "goal.jitter must hold each level once"),
    ({"jitter": "jitter = [99.0]"}, "goal.jitter must hold jitter levels in [0, 5]"),
    ({"resolution": 'resolution = "huge"'}, ": resolution must be"),
])
def test_a_bad_protocol_is_one_line_naming_the_file_and_the_key(tmp_path, change, message):
    file = tiny_protocol(tmp_path, **change)
    with pytest.raises(ValueError) as exc:
        protocol.load(file)
    text = str(exc.value)
    assert len(text.splitlines()) == 1 and str(file) in text and message in text, text
    assert " --" not in text  # a key of the file, not an option of a command


def test_an_unknown_protocol_or_a_file_that_is_no_toml_is_one_line(tmp_path):
    with pytest.raises(ValueError, match="unknown protocol 'v9'"):
        protocol.load("v9")
    bad = tmp_path / "bad.toml"
    bad.write_text("version = = 1\n")
    with pytest.raises(ValueError, match=rf"protocol {re.escape(str(bad))}: not TOML"):
        protocol.load(bad)


# --- the scores --------------------------------------------------------------------------

GOAL = {"goal_reached": False, "straight_line_m": 8.0, "distance_m": 0.0}


def test_a_robot_that_never_moves_scores_nothing():
    assert scores.goal_score(GOAL) == 0.0
    still = {"encounters": 0, "avoided": 0, "distance_m": 0.05}
    assert scores.arena_score(still, reference_m=6.0) == pytest.approx(0.05 / 6.0)


def test_the_goal_score_weighs_success_by_the_path_taken():
    assert scores.goal_score({**GOAL, "goal_reached": True, "distance_m": 8.0}) == 1.0
    assert scores.goal_score({**GOAL, "goal_reached": True, "distance_m": 10.0}) == 0.8
    # a path measured shorter than the straight line (it stopped within the goal's radius)
    assert scores.goal_score({**GOAL, "goal_reached": True, "distance_m": 7.6}) == 1.0
    assert scores.goal_score({**GOAL, "distance_m": 8.0}) == 0.0  # collided or timed out


def test_the_arena_score_is_the_share_avoided_times_the_distance_share():
    ep = {"encounters": 4, "avoided": 3, "distance_m": 3.0}
    assert scores.arena_score(ep, reference_m=6.0) == pytest.approx(0.75 * 0.5)
    assert scores.arena_score({**ep, "distance_m": 9.0}, reference_m=6.0) == 0.75
    assert scores.arena_score({**ep, "encounters": 0, "avoided": 0}, reference_m=3.0) == 1.0


def test_the_detection_score_is_balanced_accuracy():
    always = [{"seed": s, "approaching": a, "outcome": "hit" if a else "false_alarm"}
              for s in range(4) for a in (True, False, False, False)]
    assert scores.detection_parts(always).score() == 0.5
    perfect = [{**r, "outcome": "hit" if r["approaching"] else "correct_rejection"}
               for r in always]
    assert scores.detection_parts(perfect).score() == 1.0


def _parts(values: np.ndarray) -> scores.Parts:
    return scores.Parts(tuple(range(len(values))), np.stack([values, np.ones_like(values)], 1))


def test_the_paired_comparison_separates_a_small_steady_gain_and_not_noise():
    rng = np.random.default_rng(1)
    hard = rng.uniform(0, 1, 40)  # how hard each seed is: shared by both entries
    a = {t: _parts(hard) for t in scores.CLOSED_LOOP}
    b = {t: _parts(np.clip(hard + 0.05, 0, 1)) for t in scores.CLOSED_LOOP}
    shuffled = {t: _parts(rng.permutation(hard)) for t in scores.CLOSED_LOOP}
    steady = scores.compare(b, a, 500, 0)["overall"]
    assert steady["separable"] and steady["difference"] > 0
    # the same scores on other seeds: no real difference, and the test does not claim one
    assert not scores.compare(shuffled, a, 500, 0)["overall"]["separable"]
    other = {t: scores.Parts(tuple(range(1, 41)), p.sums) for t, p in a.items()}
    with pytest.raises(ValueError, match="other seeds"):
        scores.compare(a, other, 500, 0)


def test_intervals_are_the_same_for_the_same_parts():
    p = {t: _parts(np.linspace(0, 1, 10)) for t in scores.CLOSED_LOOP}
    first, again = scores.summarise(p, 300, 0), scores.summarise(p, 300, 0)
    assert first == again and first.scores["overall"] == pytest.approx(0.5)
    low, high = first.intervals["overall"]
    assert low < 0.5 < high


# --- entries -----------------------------------------------------------------------------


def test_entries_are_detectors_controllers_or_policies():
    lgmd1 = entries.parse("lgmd1/robot-image@eyes")
    assert (lgmd1.kind, lgmd1.model, lgmd1.preset, lgmd1.side) == (
        "detector", "lgmd1", "robot-image", "eyes")
    assert lgmd1.label == "lgmd1/robot-image@eyes"
    assert entries.parse("feedback").preset == "paper"
    assert entries.parse("oracle").kind == "controller"
    assert entries.parse("shipped").kind == "policy"
    steered = entries.parse("lgmd2/robot-imu@loom-steer")
    assert (steered.kind, steered.controller, steered.model, steered.preset) == (
        "detector", "loom-steer", "lgmd2", "robot-imu")
    assert (steered.label, steered.key) == ("lgmd2/robot-imu@loom-steer",
                                            "lgmd2-robot-imu-loom-steer")
    assert steered.bench_options("RoughTerrainObstacles", (1.0,))["controllers"] == (
        "loom-steer",)
    for bad, message in (("lgmd9", "not a controller, a policy folder or a detector"),
                         ("lgmd1@left", "after '@' comes a side (halves, eyes) or a controller"),
                         ("lgmd1@oracle", "or a controller that a detector drives"),
                         ("reactive", "name the detector it drives (e.g. lgmd1)"),
                         ("loom-steer", "name the detector it drives (e.g. lgmd1@loom-steer)"),
                         # "unknown model '.'", and "File name too long" with 5,000 'a's
                         ("./nope/", "no policy folder there (no nope/policy.json)"),
                         ("a" * 5000, "is 5,000 characters")):
        with pytest.raises(ValueError, match=re.escape(message)):
            entries.parse(bad)


# --- the command -------------------------------------------------------------------------




def _fake(label: str, goal: float | np.ndarray, arena: float | np.ndarray | None) -> dict:
    """A result of hand-made scores, the same on every seed or one per seed (a policy's has
    no arena)."""
    parts = {"goal": _parts(np.broadcast_to(goal, 10).astype(float))}
    if arena is not None:
        parts["arena"] = _parts(np.broadcast_to(arena, 10).astype(float))
    summary = scores.summarise(parts, 100, 0)
    goal = float(np.mean(goal))
    row = {"score": goal, "success_rate": goal, "collision_rate": 0.1,
           "false_alarms_per_min": 1.0}
    return {"entry": {"label": label}, "scores": summary.scores,
            "intervals": summary.intervals, "command": f"lgmd-sim benchmark {label}",
            "metrics": {"goal": {"1": row}, **({"arena": {"1": {"score": arena}}}
                                               if arena is not None else {})},
            "parts": {t: p.to_json() for t, p in parts.items()},
            "machine": {"cpu": "test"}, "timing": {"wall_time_s": 60.0}}


def test_the_leaderboard_ranks_by_overall_and_leaves_a_policy_unranked_after():
    from lgmd_sim.benchmark.leaderboard import markdown

    results = [_fake("policy:p", 0.9, None), _fake("low", 0.1, 0.2), _fake("high", 0.5, 0.6)]
    rows = [line for line in markdown(results, ["a", "b", "c"], 100, 0).splitlines()
            if line.startswith("| ") and "`" in line]
    assert [r.split("|")[1].strip() for r in rows] == ["1", "2", "-"]
    assert "`high`" in rows[0] and "`low`" in rows[1] and "`policy:p`" in rows[2]


def test_a_rank_counts_only_the_entries_better_beyond_doubt():
    """A chain of close neighbours does not carry one rank down the table: b is not
    separable from a, c not from b, yet c is worse than a on every seed."""
    from lgmd_sim.benchmark.leaderboard import markdown

    x = np.full(10, 0.6)
    noise = np.tile([0.3, -0.3], 5)
    a, b, c = x, x - 0.05 + noise, x - 0.1
    results = [_fake("c", c, c), _fake("a", a, a), _fake("b", b, b)]
    rows = [line for line in markdown(results, ["c", "a", "b"], 200, 0).splitlines()
            if line.startswith("| ") and "`" in line]
    assert [(r.split("|")[1].strip(), r.split("|")[2].strip()) for r in rows] == [
        ("1", "`a`"), ("=1", "`b`"), ("=2", "`c`")]


# --- every entry checked before the first episode (issue 49, items 7 and 9) ---------------




def test_a_recalibrated_built_in_does_not_take_a_shipped_preset_s_name(tmp_path, monkeypatch):
    """`--calibrate lgmd1` made the row "lgmd1/robot", the shipped preset's name with other
    parameters; the leaderboard then refused both as one entry twice."""
    from lgmd_sim.benchmark import run
    from lgmd_sim.calibration import run as calibration

    def calibrate(config, folder, options):  # what a calibration leaves, without its minutes
        folder.mkdir(parents=True)
        made = {"from": "published", "params": {"c_sig": 1.0, "threshold": 0.5}}
        (folder / "calibrated.json").write_text(json.dumps(
            {"command": "", "presets": {"lgmd1": {"robot": made}}}))

    monkeypatch.setattr(calibration, "calibrate", calibrate)
    assert "robot" in run.shipped_presets("lgmd1")
    tuned, presets = run.calibrated(entries.parse("lgmd1"), protocol.load(tiny_protocol(tmp_path)),
                                    tmp_path / "out")
    assert tuned.label == "lgmd1/robot-recalibrated"
    assert presets == tmp_path / "out" / tuned.key / run.PRESETS
    with user_presets_from(presets):
        assert models.make("lgmd1", preset="robot-recalibrated").params.c_sig == 1.0
        assert models.make("lgmd1", preset="robot").params.c_sig == pytest.approx(88.84, 1e-3)


def test_a_job_carries_the_presets_file_that_stands_in_for_the_user_s_to_its_worker(
        tmp_path):
    """A calibrated entry's preset reached the workers through LGMD_SIM_DATA_DIR, set
    around the run (a Ray cluster's never saw it); a job made within the block now carries
    what the file holds, wherever and whenever it runs."""
    from lgmd_sim.core.jobs import Job
    from lgmd_sim.core.parallel import RunOptions, run_jobs

    made = {"from": "published", "params": {"threshold": 0.5}}
    file = tmp_path / "calibrated.json"
    file.write_text(json.dumps({"presets": {"lgmd1": {"mine": made}}}))
    with user_presets_from(file):
        assert models.presets_of("lgmd1")["mine"]["threshold"] == 0.5
        jobs = [Job(f"job{i}", carrying_presets(models.presets_of), {"name": "lgmd1"})
                for i in range(2)]
    assert "mine" not in models.presets_of("lgmd1")  # the block is over in this process
    file.unlink()  # as on another machine
    got = {}
    run_jobs(jobs, lambda job, presets: got.update({job.key: presets["mine"]["threshold"]}),
             RunOptions(workers=2, progress=False))  # two worker processes
    assert got == {"job0": 0.5, "job1": 0.5}
    assert carrying_presets(models.presets_of) is models.presets_of  # outside a block


def test_a_detector_that_always_alarms_scores_0_and_one_that_never_does_0_5(tmp_path,
                                                                            monkeypatch):
    """The guide said 0.5 for both: an alarm from the first frame comes before the window
    on every looming clip, so it is no hit, and a false alarm on every other clip."""
    from lgmd_sim.benchmark import detection

    spec = "lgmd_sim.benchmark.baselines:RandomAlarm"
    presets = {name: {"from": "default", "params": {"rate_per_min": rate}}
               for name, rate in (("always", 1800.0), ("never", 0.0))}
    (tmp_path / "calibrated.json").write_text(json.dumps({"presets": {spec: presets}}))
    monkeypatch.setenv("LGMD_SIM_DATA_DIR", str(tmp_path))
    track = protocol.load(tiny_protocol(tmp_path)).detection
    clips = [c for c in detection.clips(track) if c[0] in ("Looming", "Receding")]
    got = {}
    for preset in presets:
        records = [detection.clip_job(c, spec, preset, "small", c[0] == "Looming",
                                      track.window_s) for c in clips]
        got[preset] = scores.detection_parts(records).score()
    assert got == {"always": 0.0, "never": 0.5}
    guide = " ".join((ROOT / "docs" / "guides" / "benchmark.md").read_text().split())
    assert ("never alarms scores 0.5; one that alarms from the first frame scores 0" in guide
            and "never alarms scores 0.5, one that alarms from the first frame 0" in " ".join(
                scores.__doc__.split()))


# --- smoke runs and protocols of one's own (issue 50) -------------------------------------


def test_a_smoke_run_is_every_track_on_a_handful_of_seeds_and_says_so():
    full = protocol.load()
    smoke = full.smoke()
    assert (smoke.goal.episodes, smoke.arena.episodes, smoke.detection.clips,
            smoke.stimuli.clips) == (protocol.SMOKE_SEEDS, protocol.SMOKE_SEEDS, 1, 1)
    assert (smoke.goal.jitter, smoke.arena.jitter, smoke.detection.jitter) == (
        full.goal.jitter, full.arena.jitter, full.detection.jitter)  # every level still
    assert (smoke.calibration.budget, smoke.calibration.seeds) == (protocol.SMOKE_SEEDS, 1)
    assert smoke.identity() == {**full.identity(), "smoke": True}
    assert smoke.name == "v2, smoke run"


def test_a_protocol_of_one_s_own_is_never_taken_for_a_shipped_version(tmp_path):
    assert protocol.load("v1").name == "v1"
    same = tmp_path / "copy.toml"
    same.write_bytes(protocol.PROTOCOLS["v1"].read_bytes())
    assert protocol.load(same).name == "v1"  # the shipped file, to the byte
    mine = tmp_path / "v1.toml"  # a shipped name and version, other contents
    mine.write_text(SHIPPED.replace("bootstrap = 2000", "bootstrap = 200"))
    name = protocol.load(mine).name
    assert name.startswith("v1.toml (a protocol of one's own, version 1") and name != "v1"
