"""The closed-loop benchmark's arena task: encounters and their outcome on scripted
episodes, the roam summary (rates, Wilson interval, distance relative to the Oracle), the
two ways of choosing the side as cells of their own, and a small run."""

from __future__ import annotations

import json
import math

import pytest

from lgmd_sim.benchmark import encounters
from lgmd_sim.controllers.avoid import OracleParams
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.envs.zone import TriggerZone
from lgmd_sim.signals import metrics

FPS = 30.0


def scripted(n: int, zone=(), contact=(), *, behind=()) -> list[dict]:
    """An episode of `n` frames at 30 fps, the carrier 0.1 m further along x each frame: a
    threat 0.5 s ahead on the `zone` frames, 0.5 s away behind the carrier on the `behind`
    frames, none otherwise; in contact with it on the `contact` frames."""
    infos = []
    for i in range(n):
        near = i in zone or i in behind
        infos.append({"time": i / FPS, "carrier_pos": [0.1 * i, 0.0, 0.05],
                      "threat_ttc": 0.5 if near else math.inf,
                      "threat_distance": 0.4 if near else math.inf,
                      "threat_bearing": 2.5 if i in behind else 0.1,
                      "collision": i in contact})
    return infos


def frames(a: int, b: int) -> set[int]:
    return set(range(a, b + 1))


def test_an_encounter_without_a_collision_is_avoided():
    found = encounters.encounters(scripted(60, frames(10, 20)))
    assert len(found) == 1
    e = found[0]
    assert (e.start, e.end, e.avoided) == (10, 20, True)
    assert (e.x, e.y) == pytest.approx((1.0, 0.0))  # where the carrier was at its onset


def test_an_encounter_ending_in_a_collision_is_not_avoided():
    infos = scripted(60, frames(10, 20), contact=frames(18, 25))
    assert encounters.collision_onsets(infos) == [18]
    (e,) = encounters.encounters(infos)
    assert not e.avoided and e.start == 10


def test_a_collision_just_after_the_zone_belongs_to_its_encounter():
    gap_frames = int(encounters.MERGE_GAP * FPS)
    infos = scripted(80, frames(10, 20), contact={20 + gap_frames - 2})
    (e,) = encounters.encounters(infos)
    assert not e.avoided


def test_flicker_is_one_encounter_and_distant_runs_are_two():
    flicker = frames(10, 14) | frames(17, 20)  # 0.1 s out of the zone
    (e,) = encounters.encounters(scripted(60, flicker))
    assert (e.start, e.end, e.avoided) == (10, 20, True)
    apart = frames(10, 14) | frames(30, 35)  # 0.5 s apart
    assert [(e.start, e.end) for e in encounters.encounters(scripted(60, apart))] == [
        (10, 14), (30, 35)]


def test_a_collision_outside_every_encounter_is_a_failed_encounter_of_its_own():
    # hit by something behind the carrier: never in the zone ahead
    infos = scripted(60, frames(5, 8), contact=frames(40, 42), behind=frames(35, 42))
    found = encounters.encounters(infos)
    assert [(e.start, e.avoided) for e in found] == [(5, True), (40, False)]
    assert found[1].x == pytest.approx(4.0)


def test_contact_that_breaks_for_a_frame_is_one_collision():
    infos = scripted(60, frames(10, 30), contact=frames(18, 20) | frames(22, 25) | {50})
    assert encounters.collision_onsets(infos) == [18, 50]
    assert [e.avoided for e in encounters.encounters(infos)] == [False, False]


def test_nothing_happening_is_no_encounter():
    infos = scripted(60)
    assert encounters.encounters(infos) == [] and encounters.collision_onsets(infos) == []


def test_an_encounter_still_open_at_the_end_has_no_outcome_yet():
    assert encounters.encounters(scripted(30, frames(20, 29))) == []
    # ... unless it has collided already
    (e,) = encounters.encounters(scripted(30, frames(20, 29), contact=frames(27, 29)))
    assert not e.avoided


def in_zone(threat: dict, *zone: TriggerZone) -> bool:
    """Whether `encounters` finds an encounter with `threat` (its time to collision,
    distance and bearing) on frames 10 to 20 of an episode, in `zone` or the default."""
    infos = scripted(60)
    for info in infos[10:21]:
        info.update(threat)
    return bool(encounters.encounters(infos, *zone))


def test_the_zone_is_the_oracles_trigger():
    p = OracleParams()
    base = {"threat_ttc": math.inf, "threat_distance": math.inf, "threat_bearing": 0.0}
    assert in_zone({**base, "threat_ttc": 0.99 * p.horizon})
    assert not in_zone({**base, "threat_ttc": 1.01 * p.horizon})
    assert in_zone({**base, "threat_distance": 0.9 * p.clearance})
    assert not in_zone({**base, "threat_ttc": 0.5 * p.horizon,
                        "threat_bearing": math.radians(p.ahead + 1)})
    wider = TriggerZone(horizon=3.0)  # another zone: the definition follows the params
    assert in_zone({**base, "threat_ttc": 2.0}, wider)
    assert not in_zone({**base, "threat_ttc": 2.0})
    assert f"time to collision < {p.horizon:g} s" in encounters.LEGEND
    assert f"nearer than {p.clearance:g} m" in encounters.LEGEND


def test_the_zone_and_the_oracles_trigger_are_one_test():
    """The Oracle triggers exactly where an encounter is, turning by the threat's bearing."""
    from lgmd_sim.controllers.avoid import Oracle
    from lgmd_sim.envs.zone import in_trigger_zone

    p, oracle = OracleParams(), Oracle()
    for ttc, distance, bearing in [(0.5, 2.0, 0.1), (2.0, 2.0, 0.1), (2.0, 0.2, -0.3),
                                   (0.5, 2.0, math.radians(p.ahead + 1)), (math.inf, 0.1, 3.0)]:
        info = {"threat_ttc": ttc, "threat_distance": distance, "threat_bearing": bearing}
        inside = in_trigger_zone(info, p)
        assert in_zone(info) is inside
        assert oracle._trigger({}, info) == (bearing if inside else None)


def test_an_encounter_starting_while_still_in_contact_is_not_avoided():
    """Pressed against a wall and turning on the spot, the robot leaves the zone and comes
    back: each return is an encounter with a collision, the one collision counted once."""
    infos = scripted(80, frames(10, 20) | frames(40, 50), contact=frames(18, 60))
    found = encounters.encounters(infos)
    assert [(e.start, e.avoided) for e in found] == [(10, False), (40, False)]
    # contact that began before the zone and ended before it does not fail it
    infos = scripted(80, frames(40, 50), contact=frames(10, 20))
    assert [(e.start, e.avoided) for e in encounters.encounters(infos)] == [
        (10, False), (40, True)]


def test_an_encounter_ending_too_near_the_end_to_judge_has_no_outcome():
    """The MERGE_GAP after an encounter must be seen before it counts as avoided."""
    assert encounters.encounters(scripted(30, frames(20, 27))) == []
    (e,) = encounters.encounters(scripted(30, frames(20, 27), contact={28}))
    assert not e.avoided  # a collision seen is an outcome
    gap_frames = round(encounters.MERGE_GAP * FPS)
    (e,) = encounters.encounters(scripted(30, frames(10, 29 - gap_frames)))
    assert e.avoided  # its whole window seen


# --- records and the summary --------------------------------------------------------------

def record(controller: str, seed: int, *, scenario: str = "ArenaRoam", jitter: float = 0.0,
           model: str | None = None, side: str | None = None, distance: float = 10.0,
           found: int = 0, avoided: int = 0, collisions: int = 0, share: float = 0.0,
           goal: bool = False) -> dict:
    """An episode's record as `episode.episode` writes it (one minute long)."""
    r = {"scenario": scenario, "jitter": jitter, "controller": controller, "model": model,
         "preset": "paper" if model else None, "tag": None, "side": side, "seed": seed,
         "task": "goal" if goal else "roam", "frames": 1800, "time_s": 60.0,
         "collided": collisions > 0, "goal_reached": False, "distance_m": distance,
         "alarms": 3, "false_alarms": 1, "first_alarm_ttc_s": None, "lead_time_s": None,
         "collisions": collisions, "collisions_per_min": float(collisions),
         "encounters": found, "avoided": avoided, "manoeuvring_share": share,
         "fingerprint": {"steps": 1800, "every": 25, "chain": [], "sha256": "0" * 64}}
    if goal:
        r["progress"] = 0.5
    return r


def roam_records() -> list[dict]:
    return [record("oracle", 1000, distance=10.0, found=5, avoided=5, share=0.2),
            record("oracle", 1001, distance=12.0, found=5, avoided=5, share=0.3),
            record("reactive", 1000, model="feedback", distance=6.0, found=4, avoided=3,
                   collisions=1, share=0.1),
            record("reactive", 1001, model="feedback", distance=9.0, found=6, avoided=6,
                   share=0.3),
            record("straight", 1000, distance=4.0),
            record("straight", 1001, distance=4.0)]


def test_the_roam_summary_pools_encounters_and_compares_distance_with_the_oracle():
    from lgmd_sim.benchmark import summary

    rows = {r["controller"]: r for r in summary.summarise(roam_records())}
    reactive = rows["reactive"]
    assert reactive["task"] == "roam"
    assert reactive["encounters"] == 10 and reactive["avoidance_rate"] == pytest.approx(0.9)
    assert reactive["avoidance_ci"] == pytest.approx(metrics.wilson_interval(9, 10))
    assert reactive["collisions_per_min"] == pytest.approx(0.5)  # 1 in 2 minutes
    assert reactive["false_alarms_per_min"] == pytest.approx(1.0)
    assert reactive["mean_distance_m"] == pytest.approx(7.5)
    assert reactive["distance_vs_oracle"] == pytest.approx(7.5 / 11.0)
    assert reactive["manoeuvring_share"] == pytest.approx(0.2)
    assert rows["oracle"]["distance_vs_oracle"] == pytest.approx(1.0)
    # no goal: no success rate to report, and no avoidance rate without an encounter
    assert reactive["success_rate"] is None and reactive["success_ci"] is None
    assert rows["straight"]["avoidance_rate"] is None and rows["straight"]["encounters"] == 0


def test_without_an_oracle_cell_there_is_no_oracle_relative_distance():
    from lgmd_sim.benchmark import summary

    rows = summary.summarise([r for r in roam_records() if r["controller"] != "oracle"])
    assert all(r["distance_vs_oracle"] is None for r in rows)


def test_the_oracle_distance_is_the_same_jitter_levels():
    from lgmd_sim.benchmark import summary

    records = [*roam_records(), record("oracle", 1000, jitter=1.0, distance=3.0, found=1,
                                       avoided=1),
               record("reactive", 1000, jitter=1.0, model="feedback", distance=1.5)]
    rows = {(r["controller"], r["jitter"]): r for r in summary.summarise(records)}
    assert rows[("reactive", 1.0)]["distance_vs_oracle"] == pytest.approx(0.5)
    assert rows[("reactive", 0.0)]["distance_vs_oracle"] == pytest.approx(7.5 / 11.0)


def test_the_oracle_distance_pairs_the_seeds_both_cells_have():
    from lgmd_sim.benchmark import summary

    oracle = [record("oracle", 1000, distance=10.0), record("oracle", 1001, distance=12.0),
              record("oracle", 1002, distance=20.0)]
    reactive = [record("reactive", 1000, model="feedback", distance=6.0),
                record("reactive", 1001, model="feedback", distance=None),
                record("reactive", 1003, model="feedback", distance=9.0)]
    rows = {r["controller"]: r for r in summary.summarise([*oracle, *reactive])}
    assert rows["reactive"]["distance_vs_oracle"] == pytest.approx(6.0 / 10.0)
    assert rows["oracle"]["distance_vs_oracle"] == pytest.approx(1.0)
    # no seed in common: no ratio
    rows = summary.summarise([*oracle, reactive[2]])
    assert next(r for r in rows if r["controller"] == "reactive")["distance_vs_oracle"] is None


def test_an_extra_cell_with_parameters_needs_a_tag():
    """An untagged extra oracle with other parameters would read as the planned Oracle
    (records, keys and labels carry no parameters but the side): it is refused."""
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
    from lgmd_sim.benchmark.episode import Cell

    other = Cell("ArenaRoam", 0.0, "oracle", params=(("horizon", 2.0),))
    with pytest.raises(ValueError) as exc:
        ClosedLoopConfig(scenarios=("ArenaRoam",), jitter=(0.0,), extra=(other,))
    assert "horizon" in str(exc.value) and "tag" in str(exc.value)
    assert "\n" not in str(exc.value)
    ClosedLoopConfig(scenarios=("ArenaRoam",), jitter=(0.0,),
                     extra=(Cell("ArenaRoam", 0.0, "oracle", params=(("horizon", 2.0),),
                                 tag="horizon 2"),))
    with pytest.raises(ValueError, match=r"cell oracle \(ArenaRoam, jitter 0\) is a cell of"):
        ClosedLoopConfig(scenarios=("ArenaRoam",), jitter=(0.0,),
                         extra=(Cell("ArenaRoam", 0.0, "oracle"),))
    # one driven by a detector too: its tag tells it apart from the planned cell
    planned = dict(scenarios=("ArenaRoam",), jitter=(0.0,), controllers=("loom-steer",),
                   detectors=(("lgmd1", "robot"),))
    slow = Cell("ArenaRoam", 0.0, "loom-steer", "lgmd1", "robot", (("slow", 0.0),), "slow 0")
    both = ClosedLoopConfig(**planned, extra=(slow,)).cells()
    assert [c.label for c in both] == ["loom-steer: lgmd1/robot",
                                       "loom-steer: lgmd1/robot (slow 0)"]
    assert len({c.key(0) for c in both}) == 2


def test_a_controller_that_cannot_tell_reports_no_manoeuvring_share(monkeypatch):
    """A trained policy turns away without saying so: its share is unknown ("-"), not 0."""
    import numpy as np

    from lgmd_sim import controllers
    from lgmd_sim.benchmark import episode, summary
    from lgmd_sim.core.params import CheckedParams

    class Blind(controllers.Controller):
        Params = CheckedParams

        def act(self, obs, info):
            return np.array([0.5, 0.0], np.float32)

    monkeypatch.setattr(controllers, "controller_class", lambda name: Blind)
    monkeypatch.setattr(controllers, "make", lambda name, **params: Blind())
    record_ = episode.episode(episode.Cell("StationaryApproach", 0.0, "policy", tag="b"),
                                  1000, resolution="small", cruise=0.6, horizon=2.0)
    assert record_["manoeuvring_share"] is None
    (row,) = summary.summarise([record("policy", 1000, share=None)])
    assert row["manoeuvring_share"] is None
    assert summary.summary_markdown([row]).splitlines()[2].endswith("| - |")


def test_the_sides_identify_a_run_only_where_a_controller_takes_one():
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
    from lgmd_sim.benchmark.episode import DEFAULT_SIDE
    from lgmd_sim.controllers.avoid import ReactiveParams

    assert DEFAULT_SIDE == ReactiveParams().side
    both, reversed_ = (ClosedLoopConfig(sides=("halves", "eyes")),
                       ClosedLoopConfig(sides=("eyes", "halves")))
    assert both.as_json() == reversed_.as_json()
    assert both.as_json()["sides"] == ["halves", "eyes"]  # the default first
    # the cells in the order asked for
    assert [c.side for c in reversed_.cells() if c.controller == "reactive"][:2] == [
        "eyes", None]
    # sides no controller takes make no cell: the same run as without them
    sideless = ClosedLoopConfig(controllers=("straight", "oracle"), sides=("halves", "eyes"))
    assert sideless.as_json()["sides"] == [DEFAULT_SIDE]
    assert sideless.as_json() == ClosedLoopConfig(controllers=("straight", "oracle")).as_json()


def test_a_run_folders_configuration_reads_back_as_the_one_that_ran():
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
    from lgmd_sim.benchmark.episode import Cell

    ran = ClosedLoopConfig(
        scenarios=("RobotWallAhead",), jitter=(0.0, 2.0), controllers=("oracle", "reactive"),
        detectors=(("lgmd1", "robot"),), seeds=3, first_seed=7, resolution=(60, 80),
        cruise=0.5, horizon=1.5, sides=("halves", "eyes"), top_views=2,
        extra=(Cell("RobotWallAhead", 2.0, "oracle", params=(("horizon", 0.8),), tag="h"),
               Cell("RobotWallAhead", 0.0, "loom-steer", "lgmd1", "robot",
                    params=(("slow", 0.0),), tag="s")))
    back = ClosedLoopConfig.from_json(json.loads(json.dumps(ran.as_json())))
    assert back == ran  # sides in their recorded order: the default first
    assert back.cells() == ran.cells()  # an extra cell's detector too
    assert ran.as_json()["extra"][0]["model"] is None  # every key, whatever its value
    no_extra = ClosedLoopConfig(controllers=("straight",))
    assert ClosedLoopConfig.from_json(no_extra.as_json()) == no_extra


def test_the_markdown_has_a_table_per_task_kind_each_with_its_legend(tmp_path):
    from lgmd_sim.benchmark import summary

    goal = [record(c, s, scenario="RoughTerrainObstacles", goal=True, found=2, avoided=2)
            for c in ("oracle", "straight") for s in (1000, 1001)]
    text = summary.summary_markdown(summary.summarise([*goal, *roam_records()]))
    blocks = [block.strip() for block in text.split("\n\n") if block.strip()]
    assert len(blocks) == 4  # each table, then its legend of definitions
    tables, legends = blocks[::2], blocks[1::2]
    heads = [t.splitlines()[0] for t in tables]
    assert all(len(legend.splitlines()) == 1 and legend.startswith("_") for legend in legends)
    assert "success %" in heads[0] and "avoided %" not in heads[0]
    assert "avoided %" in heads[1] and "success %" not in heads[1]
    assert "distance vs Oracle" in heads[1] and "collisions / min" in heads[1]
    assert "RoughTerrainObstacles" in tables[0] and "ArenaRoam" not in tables[0]
    assert "ArenaRoam" in tables[1] and "RoughTerrainObstacles" not in tables[1]
    assert "success" in legends[0] and encounters.LEGEND in legends[1]
    # encounters of an episode are not independent: the interval says it is too narrow
    assert "cluster by episode" in legends[1]
    # summary.csv: one row per cell, every column, empty where it does not apply
    summary.write_tables(tmp_path, [*goal, *roam_records()])
    import csv

    rows = list(csv.DictReader((tmp_path / "summary.csv").open()))
    assert len(rows) == 5 and len({tuple(r) for r in rows}) == 1
    roam = next(r for r in rows if r["scenario"] == "ArenaRoam" and r["controller"] == "oracle")
    assert roam["success_rate"] == "" and float(roam["avoidance_rate"]) == 1.0
    goal_row = next(r for r in rows if r["scenario"] == "RoughTerrainObstacles")
    assert goal_row["success_rate"] != ""


def test_a_record_missing_a_field_the_tables_read_is_refused():
    """Every field of an episode's record is required (a goal task's progress aside): a
    run folder of an older lgmd-sim is refused by its run.json's schema, never read as
    if its records were complete."""
    from lgmd_sim.benchmark import episode
    from lgmd_sim.core.runs import _mismatch

    goal = record("straight", 1000, scenario="RoughTerrainObstacles", goal=True)
    assert _mismatch(goal, episode.RECORD_FIELDS) is None
    for name in ("side", "task", "collisions", "encounters", "avoided", "manoeuvring_share"):
        old = {k: v for k, v in goal.items() if k != name}
        assert name in _mismatch(old, episode.RECORD_FIELDS)
    roam = roam_records()[0]
    assert "progress" not in roam and _mismatch(roam, episode.RECORD_FIELDS) is None


# --- the two ways of choosing the side ----------------------------------------------------

@pytest.fixture
def sided(monkeypatch):
    """ReactiveAvoid with a `side` parameter: its own, or a stand-in until it has one."""
    from dataclasses import dataclass

    from lgmd_sim.controllers import avoid
    from lgmd_sim.core.params import one_of, param

    if "side" not in avoid.ReactiveParams.names():
        @dataclass(frozen=True)
        class Sided(avoid.ReactiveParams):
            side: str = param("halves", "test", check=one_of("halves", "eyes"))

        monkeypatch.setattr(avoid, "ReactiveParams", Sided)
        monkeypatch.setattr(avoid.ReactiveAvoid, "Params", Sided)


def test_a_controller_with_a_side_gets_a_cell_per_detector_and_side(sided):
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    config = ClosedLoopConfig(scenarios=("StationaryApproach",), jitter=(0.0,),
                              detectors=(("feedback", "paper"), ("lgmd1", "published")),
                              sides=("halves", "eyes"))
    cells = config.cells()
    assert [c.label for c in cells] == [
        "straight", "oracle", "reactive: feedback/paper", "reactive: feedback/paper, eyes",
        "reactive: lgmd1/published", "reactive: lgmd1/published, eyes"]
    eyes = cells[3]
    assert eyes.params == (("side", "eyes"),) and eyes.side == "eyes"
    assert eyes.key(1000) == "StationaryApproach-j0-reactive-feedback-paper-eyes-s1000"
    # the default side: the cells, keys and labels from before there were sides
    halves = cells[2]
    assert halves.params == () and halves.side is None
    assert halves.key(1000) == "StationaryApproach-j0-reactive-feedback-paper-s1000"
    assert config.as_json()["sides"] == ["halves", "eyes"]
    assert ClosedLoopConfig().as_json()["sides"] == ["halves"]
    assert ClosedLoopConfig().cells() == ClosedLoopConfig(sides=("halves",)).cells()


def test_a_side_the_controller_lacks_is_one_line_naming_it(sided):
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig

    for sides, message in ((("both",), "sides must be a sequence of 1 or more values, each "
                            "one of 'halves', 'eyes', got ('both',)"),
                           ((), "sides must be a sequence of 1 or more values, got ()")):
        with pytest.raises(ValueError) as exc:
            ClosedLoopConfig(sides=sides)
        assert message in str(exc.value) and "\n" not in str(exc.value)


def test_the_command_takes_sides(sided, tmp_path):
    from lgmd_sim import cli
    from lgmd_sim.benchmark.closed_loop import ClosedLoopConfig
    from lgmd_sim.cli import bench as cli_bench

    keys = tmp_path / "sides.toml"
    keys.write_text('sides = ["halves", "eyes"]\n')
    args = cli.build_parser().parse_args(["bench", "closed-loop", "--config", str(keys)])
    assert cli_bench.closed_loop_config(args).sides == ("halves", "eyes")
    args = cli.build_parser().parse_args(["bench", "closed-loop"])
    assert cli_bench.closed_loop_config(args) == ClosedLoopConfig()


def test_the_summary_keeps_the_sides_apart():
    from lgmd_sim.benchmark import summary

    records = [record("reactive", 1000, model="feedback", found=2, avoided=2),
               record("reactive", 1000, model="feedback", side="eyes", found=2, avoided=1)]
    rows = {r["cell"]: r for r in summary.summarise(records)}
    assert rows["reactive: feedback/paper"]["avoidance_rate"] == 1.0
    assert rows["reactive: feedback/paper, eyes"]["avoidance_rate"] == 0.5
    assert rows["reactive: feedback/paper, eyes"]["side"] == "eyes"


# --- runs ---------------------------------------------------------------------------------

def test_each_example_is_drawn_under_its_own_cells_label(tmp_path, monkeypatch):
    """The top views reach the figures labelled with the cell that drove them (the records
    come back in key order, the cells in plan order: oracle's path was drawn as straight's)."""
    from lgmd_sim.benchmark import closed_loop, figures

    drawn = {}
    monkeypatch.setattr(figures, "closed_loop",
                        lambda folder, rows, examples: drawn.update(examples=examples))
    monkeypatch.setattr(figures, "closed_loop_figures", lambda rows, examples: ())
    config = closed_loop.ClosedLoopConfig(
        scenarios=("StationaryApproach",), jitter=(0.0,), controllers=("straight", "oracle"),
        seeds=1, resolution="small")
    closed_loop.run(config, tmp_path / "run", RunOptions(workers=1, progress=False))
    assert sorted((e["cell"], e["controller"]) for e in drawn["examples"]) == [
        ("oracle", "oracle"), ("straight", "straight")]


def test_the_benchmark_s_run_returns_its_records_draws_nothing_and_checks_once(tmp_path,
                                                                             monkeypatch):
    """`lgmd-sim benchmark` read each track's records again from its run folder, drew
    figures into every entry's folder that no page shows, and ran the preflight a second
    time; `lgmd-sim bench closed-loop` (the defaults) still checks and draws."""
    from lgmd_sim.benchmark import closed_loop, figures
    from lgmd_sim.core.runs import RunFolder
    from lgmd_sim.models import check

    checked, drawn = [], []
    monkeypatch.setattr(check, "preflight", lambda detectors: checked.append(list(detectors)))
    monkeypatch.setattr(figures, "closed_loop",
                        lambda folder, rows, examples: drawn.append(folder))
    monkeypatch.setattr(figures, "closed_loop_figures", lambda rows, examples: ())
    config = closed_loop.ClosedLoopConfig(
        scenarios=("StationaryApproach",), jitter=(0.0,), controllers=("straight", "reactive"),
        detectors=(("lgmd1", "published"),), seeds=1, resolution="small")
    options = RunOptions(workers=1, progress=False, resume=True)
    result = closed_loop.run(config, tmp_path / "run", options, figures=False,
                             preflighted=True)
    assert (checked, drawn) == ([], [])
    assert result.files == ["episodes.csv", "summary.csv", "summary.md", "run.json"]
    assert sorted(p.name for p in result.path.iterdir() if p.is_file()) == sorted(result.files)
    stored = RunFolder(result.path, config.as_json(), "", resume=True, start=False).records()
    assert result.records == [{k: v for k, v in r.items() if k != "top_view"}
                              for r in stored]
    assert [r["controller"] for r in result.records] == ["reactive", "straight"]
    closed_loop.run(config, tmp_path / "run", options)
    assert checked == [[("lgmd1", "published")]] and len(drawn) == 1


@pytest.mark.slow
def test_the_arena_run_counts_encounters_and_draws_where_they_happened(tmp_path):
    """ArenaRoam, oracle and straight, one seed: the records carry the arena's figures,
    the summary its table, and the figures are the roam task's (no success rate)."""
    import csv
    import json

    from lgmd_sim.benchmark import closed_loop, figures

    config = closed_loop.ClosedLoopConfig(
        scenarios=("ArenaRoam",), jitter=(0.0,), controllers=("straight", "oracle"), seeds=1,
        resolution="small")
    result = closed_loop.run(config, tmp_path / "arena", RunOptions(workers=1, progress=False))
    out = result.path
    records = {r["controller"]: r for r in csv.DictReader((out / "episodes.csv").open())}
    assert {r["task"] for r in records.values()} == {"roam"}
    for r in records.values():
        assert float(r["time_s"]) == pytest.approx(30.0, abs=0.1)  # collisions go on
        assert int(r["avoided"]) <= int(r["encounters"])
        assert 0 <= float(r["manoeuvring_share"]) <= 1
    assert float(records["straight"]["manoeuvring_share"]) == 0  # it never manoeuvres
    assert float(records["oracle"]["manoeuvring_share"]) > 0
    assert int(records["straight"]["collisions"]) >= 1  # straight into a wall, at the latest
    rows = {r["controller"]: r for r in result.rows}
    assert rows["oracle"]["distance_vs_oracle"] == pytest.approx(1.0)
    assert rows["straight"]["success_rate"] is None
    oracle_record = json.loads((out / "records" / "ArenaRoam-j0-oracle-s1000.json").read_text())
    marks = oracle_record["top_view"]["encounters"]
    assert len(marks) == oracle_record["encounters"]
    assert all(len(m) == 3 and isinstance(m[2], bool) for m in marks)
    pngs = {p.name for p in out.glob("*.png")}
    assert pngs == {*figures.CLOSED_LOOP, figures.ARENA_VS_JITTER, "encounters_ArenaRoam_j0.png"}
    assert set(result.files) >= pngs
    assert "avoided %" in (out / "summary.md").read_text()


# --- figures ------------------------------------------------------------------------------

def roam_example(controller: str, marks: list) -> dict:
    view = {"obstacles": [{"polygon": [[2.6, -0.3], [3.2, -0.3], [3.2, 0.3], [2.6, 0.3]]},
                          {"circle": [5.0, 1.0, 0.25]}],
            "goal": None, "path": [[0.0, 0.0], [1.0, 0.0], [2.0, 0.5], [3.0, 1.0]],
            "collision_frame": None, "encounters": marks}
    return {"scenario": "ArenaRoam", "jitter": 0.0, "seed": 1000, "controller": controller,
            "model": None, "preset": None, "tag": None, "cell": controller, "top_view": view}


def test_roam_figures_mark_each_encounter_and_report_no_success(tmp_path, monkeypatch):
    from matplotlib.colors import to_rgb

    from lgmd_sim.benchmark import figures, summary

    goal = [record(c, 1000, scenario="RoughTerrainObstacles", goal=True, found=1, avoided=1)
            for c in ("oracle", "straight")]
    rows = summary.summarise([*goal, *roam_records()])
    examples = [roam_example("oracle", [[1.0, 0.0, True], [2.0, 0.5, True]]),
                roam_example("straight", [[1.0, 0.0, True], [3.0, 1.0, False]])]
    made = {}
    monkeypatch.setattr(figures, "save_figure", lambda fig, path: (made.update({path.name: fig}),
                                                             path.write_bytes(b"png")))
    figures.closed_loop(tmp_path, rows, examples)
    names = figures.closed_loop_figures(rows, examples)
    assert set(made) == set(names) == {*figures.CLOSED_LOOP, figures.ARENA_VS_JITTER,
                                       "encounters_ArenaRoam_j0.png"}
    # a task without a goal has no success rate: the share of encounters avoided instead
    titles = {name: [ax.get_title() for ax in fig.axes] for name, fig in made.items()}
    goal_titles = [t for t in titles["collisions_vs_jitter.png"] if "Rough" in t]
    roam_titles = [t for t in titles["collisions_vs_jitter.png"] if "ArenaRoam" in t]
    assert any("success" in t for t in goal_titles)
    assert len(roam_titles) == 2 and not any("success" in t for t in roam_titles)
    assert any("avoided" in t for t in roam_titles)
    assert not any("success" in t for t in titles[figures.ARENA_VS_JITTER])
    assert any("avoided" in t for t in titles[figures.ARENA_VS_JITTER])
    # each encounter where it happened: green circles avoided, red crosses not
    panels = {ax.get_title().split(":")[0]: ax for ax in made["encounters_ArenaRoam_j0.png"].axes
              if ax.get_title()}

    def marks(ax, style: dict) -> list:
        """Where the axes show single markers of `style`'s shape and colour."""
        colour = to_rgb(style.get("mec") if style["marker"] == "o" else style["color"])
        return sorted((float(ln.get_xdata()[0]), float(ln.get_ydata()[0]))
                      for ln in ax.get_lines() if len(ln.get_xdata()) == 1
                      and ln.get_marker() == style["marker"]
                      and colour in (to_rgb(ln.get_markeredgecolor()), to_rgb(ln.get_color())))

    avoided, failed = figures._AVOIDED, figures._FAILED
    assert marks(panels["oracle"], avoided) == [(1.0, 0.0), (2.0, 0.5)]
    assert marks(panels["oracle"], failed) == []
    assert marks(panels["straight"], avoided) == [(1.0, 0.0)]
    assert marks(panels["straight"], failed) == [(3.0, 1.0)]
    assert "1 of 2 avoided" in panels["straight"].get_title()


def test_a_roam_task_plots_collisions_per_minute_against_false_alarms(tmp_path, monkeypatch):
    """Over a fixed time nearly every roam episode touches something: the collision rate
    is about 1 for every cell, collisions per minute tell them apart."""
    from lgmd_sim.benchmark import figures, summary

    goal = [record("oracle", 1000, scenario="RoughTerrainObstacles", goal=True, collisions=1)]
    roam = [record("straight", s, collisions=c) for s, c in ((1000, 3), (1001, 6))]
    rows = summary.summarise([*goal, *roam])
    made = {}
    monkeypatch.setattr(figures, "save_figure", lambda fig, path: made.update({path.name: fig}))
    figures.closed_loop(tmp_path, rows, [])
    axes = {ax.get_title(): ax for ax in made["false_alarms_vs_collisions.png"].axes}
    roam_ax, goal_ax = axes["ArenaRoam, jitter 0"], axes["RoughTerrainObstacles, jitter 0"]
    assert [float(ln.get_ydata()[0]) for ln in roam_ax.get_lines()] == [4.5]  # 9 in 2 min
    assert [float(ln.get_ydata()[0]) for ln in goal_ax.get_lines()] == [1.0]
    assert roam_ax.get_ylabel() == "collisions per minute"
    assert goal_ax.get_ylabel() == "collision rate"
    assert roam_ax.get_ylim()[1] > 4.5


def test_the_world_drawing_helpers_are_public():
    from lgmd_sim.benchmark import drawing as figures

    assert {"draw_world", "map_bounds"} <= set(figures.__all__)


def test_a_path_that_goes_on_after_a_collision_ends_at_its_end(tmp_path, monkeypatch):
    """Without termination on collision the path goes on: it is drawn to its end, the
    cross at its first collision."""
    from lgmd_sim.benchmark import figures, summary

    rows = summary.summarise([record("straight", 1000, found=1, collisions=1)])
    example = roam_example("straight", [[1.0, 0.0, False]])
    example["top_view"]["collision_frame"] = 1
    made = {}
    monkeypatch.setattr(figures, "save_figure", lambda fig, path: made.update({path.name: fig}))
    figures.closed_loop(tmp_path, rows, [example])
    (ax,) = [a for a in made["trajectories.png"].axes if a.get_lines()]
    singles = {ln.get_marker(): (float(ln.get_xdata()[0]), float(ln.get_ydata()[0]))
               for ln in ax.get_lines() if len(ln.get_xdata()) == 1}
    assert singles[figures._FAILED["marker"]] == (1.0, 0.0)  # the collision
    (path,) = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 1]
    assert (float(path.get_xdata()[-1]), float(path.get_ydata()[-1])) == (3.0, 1.0)  # the end
