"""`lgmd-sim verify` replays a row here and names what was changed; a numeric mode that
is none is one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lgmd_sim import cli
from lgmd_sim.core import numerics

from protocols import tiny_protocol


def test_a_numerics_mode_that_is_none_is_one_line(capsys, monkeypatch):
    monkeypatch.setenv(numerics.VARIABLE, "fast")
    assert cli.main(["envs"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "lgmd-sim envs: error: LGMD_SIM_NUMERICS=fast: give one of replay, host"


@pytest.fixture(scope="module")
def straight_row(tmp_path_factory):
    """`straight` through a tiny protocol: a result, its run folders, its records."""
    tmp = tmp_path_factory.mktemp("row")
    tiny = tiny_protocol(tmp)
    assert cli.main(["benchmark", "straight", "--protocol", str(tiny), "--out",
                     str(tmp / "out"), "--workers", "1", "--no-progress"]) == 0
    return tiny, tmp / "out" / "straight"


def _verify(tiny: Path, row: Path, capsys) -> tuple[int, str, str]:
    code = cli.main(["verify", str(row), "--protocol", str(tiny), "--all", "--workers", "1",
                     "--no-progress"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.slow  # a tiny benchmark, then its replay: about 20 s
def test_verify_says_a_row_replays_here_and_names_what_was_changed(straight_row, tmp_path,
                                                                   capsys):
    tiny, row = straight_row
    code, out, _ = _verify(tiny, row, capsys)
    assert code == 0 and "4 of 4 episodes identical, numerics replay" in out, out
    copy = tmp_path / "straight"
    import shutil

    shutil.copytree(row, copy)
    record = sorted((copy / "arena" / "records").glob("*.json"))[0]
    data = json.loads(record.read_text())
    data["min_clearance_m"] += 1.0  # a measure the scores do not read
    record.write_text(json.dumps(data))
    code, out, err = _verify(tiny, copy, capsys)
    assert code == 1 and f"{record.stem}: the same trajectory, but its record's " \
        "min_clearance_m" in out and "does not replay here" in err, out
    data["fingerprint"]["chain"][0] = "0" * 16
    data["fingerprint"]["sha256"] = "0" * 64
    record.write_text(json.dumps(data))
    code, out, _ = _verify(tiny, copy, capsys)
    assert code == 1 and f"{record.stem}: diverged at step 0" in out, out
    goal = sorted((copy / "goal" / "records").glob("*.json"))[0]
    data = json.loads(goal.read_text())
    data["goal_reached"], data["straight_line_m"], data["distance_m"] = True, 1.0, 1.0
    goal.write_text(json.dumps(data))
    code, _, err = _verify(tiny, copy, capsys)
    assert code == 2 and "its goal parts are not what the episodes' records" in err, err
