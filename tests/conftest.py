"""Shared fixtures: lgmd-sim installed from a wheel, outside the checkout."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def wheel(tmp_path_factory) -> Path:
    """A wheel built from the checkout."""
    out = tmp_path_factory.mktemp("wheel")
    # From a copy without the checkout's build outputs: a stale build/ or the editable
    # install's egg-info (its SOURCES.txt) would add modules a user's wheel lacks.
    source = tmp_path_factory.mktemp("source") / "lgmd-sim"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "dist", "*.egg-info", "runs", "__pycache__", ".*_cache",
        "*.mp4", "demo-out", "detect-out"))
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(out), str(source)],
        check=True, capture_output=True,
    )
    (built,) = out.glob("lgmd_sim-*.whl")
    return built


@pytest.fixture(scope="session")
def installed(wheel, tmp_path_factory) -> dict[str, str]:
    """The wheel installed into a folder of its own: the environment variables that run it
    (its package and its `lgmd-sim` command first; the dependencies from this venv)."""
    target = tmp_path_factory.mktemp("site")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
         str(wheel)],
        check=True, capture_output=True,
    )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "MUJOCO_GL")}
    env["PYTHONPATH"] = str(target)
    env["PATH"] = os.pathsep.join([str(target / "bin"), str(Path(sys.executable).parent),
                                   "/usr/bin", "/bin"])
    return env


@pytest.fixture
def distribution(tmp_path, monkeypatch):
    """Install a distribution "myplug" on sys.path: ``distribution(entry_points)`` with the
    text of its entry points in the group lgmd_sim.models."""
    def install(entry_points: str) -> None:
        info = tmp_path / "myplug-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: myplug\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text(f"[lgmd_sim.models]\n{entry_points}")
        monkeypatch.syspath_prepend(str(tmp_path))
    return install


@pytest.fixture
def test_plugins_on_path(monkeypatch):
    """tests/plugins on sys.path: the test plug-ins by their specs (hostile:Mutating,
    lgmd_plug:..., eta_broken:...)."""
    monkeypatch.syspath_prepend(str(ROOT / "tests" / "plugins"))


@pytest.fixture
def examples_on_path(monkeypatch):
    """examples/ on sys.path, as `PYTHONPATH=examples` puts it for a user: the worked
    plug-in by its spec, eta_lgmd:EtaLGMD."""
    monkeypatch.syspath_prepend(str(ROOT / "examples"))


@pytest.fixture
def fresh_registries():
    """The model and controller registries as the session began for the test (nothing
    registered, the entry points read afresh), and as they were after it."""
    from lgmd_sim import controllers, models

    with models._MODELS.isolated(), controllers._CONTROLLERS.isolated():
        yield


@pytest.fixture(scope="session")
def approach(tmp_path_factory):
    """A video of an approach (48 x 64, grey as BGR), and its clip."""
    import cv2

    from lgmd_sim.signals import stimuli

    clip = stimuli.approaching((48, 64), start_distance=1.0, speed=2.0, still_frames=3,
                               look=stimuli.Look(background="texture"))
    video = tmp_path_factory.mktemp("video") / "approach.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (64, 48))
    for f in clip.frames:
        writer.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
    writer.release()
    return video, clip


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory) -> Path:
    """The tiny dataset of tests/datasets_tiny.py, generated once: collisions
    (HandheldApproach) and near misses (PassBy)."""
    from lgmd_sim.core.parallel import RunOptions
    from lgmd_sim.data.generate import generate

    from datasets_tiny import CONFIG

    out = tmp_path_factory.mktemp("data") / "tiny"
    generate(CONFIG, out, RunOptions(workers=1, progress=False))
    return out
