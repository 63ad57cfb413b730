"""`lgmd-sim demo`: a bad detector or avoider is one line before any episode; the avoiding
episode's files are written beside the others, and --no-avoid removes an earlier run's."""

from __future__ import annotations

from pathlib import Path

import pytest

from lgmd_sim import cli
from lgmd_sim.apps import demo
from lgmd_sim.apps.defaults import AVOIDER
from lgmd_sim.cli import demo as demo_cli
from lgmd_sim.core.pngtext import png_text

DEMO = ["--resolution", "small", "--models", "feedback/paper", "--avoid-resolution", "small",
        "--avoid-seed", "3"]


def test_an_unknown_detector_is_refused_before_the_episode(tmp_path, capsys):
    assert cli.main(["demo", "--models", "lgmd2/nope", "--out", str(tmp_path / "d")]) == 2
    assert "unknown preset 'nope'" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@pytest.mark.slow
def test_the_demo_writes_the_avoiding_episode_with_its_other_files(tmp_path, capsys):
    out = tmp_path / "d"
    assert cli.main(["demo", "--out", str(out), *DEMO]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "avoid.mp4", "avoid.png", "demo.mp4", "demo.png", "demo_frame.png"]
    printed = capsys.readouterr().out
    detector, side = AVOIDER.split(",")
    assert f"avoiding ({detector}, {side}, seed 3)" in printed
    assert str((out / "avoid.png").resolve()) in printed


def test_no_avoid_skips_it_and_removes_an_earlier_runs_avoiding_episode(tmp_path):
    out = tmp_path / "d"
    out.mkdir()
    for name in ("avoid.mp4", "avoid.png", "notes.txt"):  # an earlier run's, and the user's
        (out / name).write_text("earlier")
    assert cli.main(["demo", "--out", str(out), *DEMO, "--no-avoid"]) == 0
    # the folder reads as one set: no avoiding episode of another run beside this one
    assert sorted(p.name for p in out.iterdir()) == [
        "demo.mp4", "demo.png", "demo_frame.png", "notes.txt"]


@pytest.mark.parametrize(("avoider", "named"), [
    ("lgmd2/nope", "unknown preset 'nope'"),
    ("lgmd1,sideways", "unknown controller 'sideways'"),
    ("lgmd1,oracle", "a side (halves, eyes) or a controller that a detector drives"),
])
def test_an_unknown_avoider_is_one_line_before_any_episode(tmp_path, capsys, avoider, named):
    assert cli.main(["demo", "--avoider", avoider, "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--avoider '{avoider}'" in err and named in err, err
    assert not (tmp_path / "d").exists()


def test_the_demo_records_its_command_and_episodes_in_every_png(tmp_path, monkeypatch):
    """`lgmd-sim demo` writes what the check above reads (the episodes stubbed: the
    files' writing is what is tested)."""
    recorded = {}

    def writer(name):
        def write(ep, *paths_and_text):
            *paths, text = paths_and_text
            recorded[name] = text
            for p in paths:
                Path(p).write_bytes(b"")
        return write

    monkeypatch.setattr(demo, "drive", lambda *a, **k: type("E", (), {
        "frames": [], "collision_frame": None, "first_alarm": lambda self, n: None})())
    from lgmd_sim.apps import avoid as demo_avoid

    monkeypatch.setattr(demo_avoid, "drive", lambda *a, **k: type("A", (), {
        "detector": "lgmd1", "how": "loom-steer", "frames": [], "outcome": "collided",
        "onsets": []})())
    monkeypatch.setattr(demo, "write_video", writer("video"))
    monkeypatch.setattr(demo, "write_summary", lambda ep, path, title, text: (
        recorded.setdefault("summary", text), Path(path).write_bytes(b"")))
    monkeypatch.setattr(demo_avoid, "write", writer("avoid"))
    argv = ["demo", "--out", str(tmp_path / "d"), "--avoid-seed", "5"]
    assert cli.main(argv) == 0
    args = cli.build_parser().parse_args(argv)
    expected = png_text(cli.command_line(argv), demo.configuration(**demo_cli.episodes(args)))
    assert recorded == {"video": expected, "summary": expected, "avoid": expected}
    assert '"avoid_seed": 5' in expected["lgmd-sim:config"]
