"""Calibrated presets: shipped with the package, a user's on top, saving merges, and the
package is never written by a calibration."""

from __future__ import annotations

import errno
import hashlib
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from lgmd_sim import cli, models
from lgmd_sim.core.fileio import error_text
from lgmd_sim.models import presets

ROOT = Path(__file__).resolve().parents[2]
TOOLS = ROOT / "docs" / "experiments" / "tools"  # the research log's scripts
TINY = ["--budget", "1", "--seeds", "1", "--resolution", "small", "--workers", "1",
        "--no-progress"]


@pytest.fixture
def user_dir(tmp_path, monkeypatch):
    """An empty user data folder, and a copy of the shipped presets standing in for them
    (so that nothing here can touch the package's file)."""
    folder = tmp_path / "user-data"
    monkeypatch.setenv("LGMD_SIM_DATA_DIR", str(folder))
    shipped = tmp_path / "shipped.json"
    shutil.copyfile(presets.CALIBRATED, shipped)
    monkeypatch.setattr(presets, "CALIBRATED", shipped)
    return folder


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _calibration(entries: dict[str, dict[str, dict]], command: str = "lgmd-sim calibrate x"
                 ) -> dict:
    """A calibration's calibrated.json, as `calibrate` writes it."""
    return {"command": command, "objective": "o", "search_seeds": [0, 1],
            "heldout_seeds": [100, 1], "resolution": "small", "budget": 1,
            "figure": "calibration.png", "presets": entries}


def _entry(base: str, **params) -> dict:
    score = {"objective": 1.0, "jitter": 1.0, "stationary": 1.0, "near_miss": 1.0}
    return {"from": base, "params": params, "search": score, "heldout": score}


def test_saving_twice_merges_and_each_preset_keeps_its_calibration(tmp_path):
    target = tmp_path / "mine.json"
    presets.merge_presets(target, _calibration(
        {"lgmd1": {"calibrated": _entry("published", c_sig=2.0)},
         "feedback": {"calibrated": _entry("paper", mu=2.0)}}, "lgmd-sim calibrate A"))
    presets.merge_presets(target, _calibration(
        {"feedback": {"calibrated": _entry("paper", mu=5.0)}}, "lgmd-sim calibrate B"))
    data = json.loads(target.read_text())["presets"]
    assert data["lgmd1"]["calibrated"]["params"] == {"c_sig": 2.0}
    assert data["lgmd1"]["calibrated"]["calibration"]["command"] == "lgmd-sim calibrate A"
    assert data["feedback"]["calibrated"]["params"] == {"mu": 5.0}
    assert data["feedback"]["calibrated"]["calibration"]["command"] == "lgmd-sim calibrate B"
    assert not list(tmp_path.glob(".*partial*"))


# one process's merges: each a preset of its own, once every process is ready (a file "go")
MERGE_MANY = """
import sys, time
from pathlib import Path
from lgmd_sim.models.presets import merge_presets
target, me, count = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
(target.parent / f"ready-{me}").touch()
while not (target.parent / "go").exists():
    time.sleep(0.001)
for i in range(count):
    merge_presets(target, {"command": f"calibrate {me}", "presets": {
        "lgmd1": {f"{me}-{i}": {"from": "published", "params": {"c_sig": 2.0}}}}})
"""


def test_concurrent_merges_into_one_file_keep_every_preset(tmp_path):
    target, count, names = tmp_path / "calibrated.json", 40, ["a", "b", "c"]
    procs = [subprocess.Popen([sys.executable, "-c", MERGE_MANY, str(target), me, str(count)])
             for me in names]
    while not all((tmp_path / f"ready-{me}").exists() for me in names):
        assert all(p.poll() is None for p in procs)
        time.sleep(0.01)
    (tmp_path / "go").touch()
    assert [p.wait(timeout=60) for p in procs] == [0] * len(names)
    saved = json.loads(target.read_text())["presets"]["lgmd1"]
    assert set(saved) == {f"{me}-{i}" for me in names for i in range(count)}
    assert saved["b-7"]["calibration"]["command"] == "calibrate b"


@pytest.fixture
def read_only(monkeypatch):
    """Make a folder read-only as a read-only file system does: nothing in it can be made
    or written. At the `os` level, since the suite may run as root, whom a folder's
    permissions do not stop."""
    real_open, real_mkdir = os.open, os.mkdir

    def make(folder: Path) -> None:
        def check(path: str | os.PathLike) -> None:
            given = Path(os.fsdecode(path)).absolute()
            if given == folder or folder in given.parents:
                raise OSError(errno.EROFS, os.strerror(errno.EROFS), os.fsdecode(path))

        def open_(path, flags, *args, **kwargs):
            if flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
                check(path)
            return real_open(path, flags, *args, **kwargs)

        def mkdir(path, *args, **kwargs):
            check(path)
            return real_mkdir(path, *args, **kwargs)

        monkeypatch.setattr(os, "open", open_)
        monkeypatch.setattr(os, "mkdir", mkdir)

    return make


def test_a_merge_that_cannot_write_names_the_presets_file_not_its_temporary(
        tmp_path, read_only):
    folder = tmp_path / "read-only"
    folder.mkdir()
    read_only(folder)
    target = folder / "p.json"
    with pytest.raises(OSError) as err:
        presets.merge_presets(target, _calibration(
            {"lgmd1": {"calibrated": _entry("published", c_sig=2.0)}}))
    assert error_text(err.value) == (f"cannot write presets file {target}: "
                                     "Read-only file system")


def test_the_release_step_merges_a_calibration_into_the_shipped_file(tmp_path):
    spec = importlib.util.spec_from_file_location("ship_presets",
                                                  TOOLS / "ship_presets.py")
    ship = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ship)
    shipped = tmp_path / "shipped.json"
    shutil.copyfile(presets.CALIBRATED, shipped)
    run = tmp_path / "run"
    run.mkdir()
    (run / "calibrated.json").write_text(json.dumps(_calibration(
        {"lgmd2": {"calibrated": _entry("published", c_sig=3.0)}})))
    ship.ship(run, shipped)
    data = json.loads(shipped.read_text())["presets"]
    assert data["lgmd2"]["calibrated"]["params"] == {"c_sig": 3.0}
    assert "calibrated-image" in data["lgmd2"] and "calibrated-image" in data["feedback"]
    with pytest.raises(SystemExit, match=r"calibrated\.json"):
        ship.ship(tmp_path, shipped)


def _chosen(names: list[str]) -> list[dict]:
    score = {"objective": 0.6, "jitter": 0.5, "stationary": 1.0, "near_miss": 0.25}
    return [{"detector": n, "search": score, "heldout": score} for n in names]


@pytest.mark.parametrize("names", [
    ["feedback"], ["feedback-open-loop"], ["lgmd1", "feedback-open-loop", "lgmd1+image"],
    ["feedback", "feedback-open-loop", "lgmd1", "lgmd2", "f_on", "feedback+image",
     "feedback-open-loop+image", "lgmd1+image", "lgmd2+image", "f_on+image"],
])
def test_calibration_png_lays_out_with_one_or_many_detectors(names):
    from lgmd_sim.calibration.report import calibration_figure

    fig = calibration_figure(_chosen(names))
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    page = fig.bbox
    titles = [ax.title.get_window_extent(renderer) for ax in fig.axes]
    legend = fig.legends[0].get_window_extent(renderer)
    for box in [*titles, legend]:  # nothing clipped
        assert page.x0 <= box.x0 and box.x1 <= page.x1 and box.y1 <= page.y1, box
    for i, a in enumerate(titles):  # no title runs into another
        assert not any(a.overlaps(b) for b in titles[i + 1:])
    axes = [ax.get_window_extent(renderer) for ax in fig.axes]
    assert not any(legend.overlaps(a) for a in axes)


@pytest.mark.slow
def test_a_subset_calibration_merges_into_the_user_file_and_leaves_the_package(
        user_dir, tmp_path):
    shipped = presets.CALIBRATED
    before = _digest(shipped)
    shipped_lgmd1 = models.presets_of("lgmd1")["calibrated"]
    out = tmp_path / "cal"
    assert cli.main(["calibrate", "--detectors", "feedback-open-loop", *TINY, "--out",
                     str(out), "--save-presets"]) == 0
    assert _digest(shipped) == before  # the package's presets are as shipped
    saved = json.loads((user_dir / "calibrated.json").read_text())
    assert list(saved["presets"]) == ["feedback"]
    mine = json.loads((out / "calibrated.json").read_text())["presets"]["feedback"]
    loop = models.presets_of("feedback")["calibrated-open-loop"]
    assert loop["threshold"] == mine["calibrated-open-loop"]["params"]["threshold"]
    # every other preset stays: the shipped ones of this model and of the others
    assert models.make("feedback", preset="calibrated-image").params.stabilize == "image"
    assert models.presets_of("lgmd1")["calibrated"] == shipped_lgmd1
    # the demo's detector still resolves
    assert models.parse_spec("feedback/calibrated-image") == ("feedback", "calibrated-image")


def test_user_presets_override_the_shipped_ones_and_models_says_whose(user_dir, capsys):
    presets.merge_presets(presets.user_presets_file(), _calibration(
        {"feedback": {"calibrated": _entry("paper", mu=7.0, threshold=0.9)}}))
    m = models.make("feedback", preset="calibrated")
    assert (m.params.mu, m.params.threshold) == (7.0, 0.9)
    assert models.make("feedback", preset="calibrated-image").params.stabilize == "image"
    assert presets.preset_files("feedback")["calibrated"] == presets.user_presets_file()
    assert presets.preset_files("feedback")["calibrated-image"] == presets.CALIBRATED
    assert cli.main(["models", "feedback"]) == 0
    out = capsys.readouterr().out
    assert f"calibrated ({presets.user_presets_file()})" in out
    assert "calibrated-image (shipped)" in out


@pytest.mark.parametrize("text", [
    "{not json", "[]", '{"presets": []}', '{"presets": {"feedback": {"calibrated": 3}}}',
    '{"presets": {"feedback": {"calibrated": {"params": {}}}}}',
    '{"presets": {"feedback": {"calibrated": {"from": "nope", "params": {}}}}}',
    '{"presets": {"feedback": {"paper": {"from": "paper", "params": {}}}}}',
])
def test_a_corrupt_user_presets_file_is_one_line_naming_it(user_dir, capsys, text):
    path = presets.user_presets_file()
    path.parent.mkdir(parents=True)
    path.write_text(text)
    with pytest.raises(ValueError, match=re.escape(str(path))) as err:
        models.make("feedback")
    assert "\n" not in str(err.value)
    assert cli.main(["models", "feedback"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0]


def test_a_corrupt_target_is_refused_before_the_calibration_starts(user_dir, tmp_path, capsys):
    path = presets.user_presets_file()
    path.parent.mkdir(parents=True)
    path.write_text("{")
    out = tmp_path / "cal"
    assert cli.main(["calibrate", "--detectors", "lgmd1", *TINY, "--out", str(out),
                     "--save-presets"]) == 2
    assert str(path) in capsys.readouterr().err
    assert not out.exists() and path.read_text() == "{"


@pytest.mark.slow
def test_presets_file_writes_there_and_never_into_the_package(user_dir, tmp_path, capsys):
    package_file = Path(models.__file__).with_name("calibrated.json")
    assert cli.main(["calibrate", "--detectors", "lgmd1", *TINY, "--out",
                     str(tmp_path / "cal"), "--save-presets", str(package_file)]) == 2
    assert "ship_presets.py" in capsys.readouterr().err
    assert not (tmp_path / "cal").exists()
    target = tmp_path / "elsewhere" / "p.json"
    assert cli.main(["calibrate", "--detectors", "lgmd1", *TINY, "--out",
                     str(tmp_path / "cal"), "--save-presets", str(target)]) == 0
    assert list(json.loads(target.read_text())["presets"]["lgmd1"]) == ["calibrated"]
    assert not user_dir.exists()


@pytest.mark.parametrize(("params", "named"), [
    ({"bogus": 1}, "unknown parameter(s) 'bogus'; valid: alarm_frames"),
    ({"c_sig": -3}, "parameter c_sig=-3 must be"),
])
def test_a_user_preset_with_an_unknown_or_bad_parameter_is_refused_naming_file_preset_and_key(
        user_dir, tmp_path, capsys, params, named):
    path = presets.user_presets_file()
    path.parent.mkdir(parents=True)
    # a plug-in's presets whose model is not installed now stay the user's business
    path.write_text(json.dumps({"presets": {
        "lgmd1": {"mine": {"from": "published", "params": params}},
        "absent_pkg.looming:Mine": {"fast": {"from": "default", "params": {"any": 1}}}}}))
    with pytest.raises(ValueError, match=re.escape(f"presets file {path}: preset lgmd1/mine: "
                                                   f"{named}")):
        models.make("lgmd1", preset="mine")
    assert models.make("lgmd2", preset="calibrated").params.threshold > 0
    frames = tmp_path / "frames"
    frames.mkdir()
    for i in range(3):
        cv2.imwrite(str(frames / f"{i}.png"), np.full((32, 32), 40 * i, np.uint8))
    assert cli.main(["detect", str(frames), "--models", "lgmd1", "--preset", "mine", "--out",
                     str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "lgmd1/mine" in err and named in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("where", "reason"), [
    ("p.json", "its folder {folder} cannot be written"),
    ("new/p.json", "its folder {folder}/new cannot be made in {folder}"),
    ("there.json", "it cannot be written"),
])
def test_an_unwritable_presets_file_is_refused_before_the_calibration_naming_it(
        user_dir, tmp_path, read_only, capsys, where, reason):
    folder = tmp_path / "read-only"
    folder.mkdir()
    presets.merge_presets(folder / "there.json", _calibration({}))
    read_only(folder)
    out, target = tmp_path / "cal", folder / where
    assert cli.main(["calibrate", "--detectors", "lgmd1", *TINY, "--out", str(out),
                     "--save-presets", str(target)]) == 2
    err = capsys.readouterr().err
    assert err == (f"lgmd-sim calibrate: error: presets file {target}: "
                   f"{reason.format(folder=folder)}: Read-only file system\n")
    assert not out.exists()


def test_the_user_data_folder(monkeypatch, tmp_path):
    monkeypatch.setenv("LGMD_SIM_DATA_DIR", str(tmp_path / "d"))
    assert presets.user_presets_file() == tmp_path / "d" / "calibrated.json"
    monkeypatch.delenv("LGMD_SIM_DATA_DIR")
    if sys.platform in ("win32", "darwin"):
        return
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert presets.user_data_dir() == tmp_path / "xdg" / "lgmd-sim"
    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert presets.user_data_dir() == tmp_path / "home" / ".local" / "share" / "lgmd-sim"
