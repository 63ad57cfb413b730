"""`python -m scripts.speed`: each benchmark prints its tables, with each target and its
verdict from the same run, at tiny sizes; a bad option exits 2."""

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from lgmd_sim import models
from scripts.speed.__main__ import main

ROOT = Path(__file__).resolve().parents[2]
#: run from the checkout's root, as a maintainer does
SPEED = [sys.executable, "-m", "scripts.speed"]
ENV = "lgmd_sim/StationaryApproach-v0"

#: A stand-in for the published Python LGMD's file: its class reads the clip it is given
#: (checking it is the comparison's) and takes half a second over it.
FAKE_PUBLISHED = """
import time
import cv2

class LGMD_P_ON_OFF:
    def __init__(self, path):
        self.video = cv2.VideoCapture(path)

    def run(self):
        frames = []
        while True:
            ok, frame = self.video.read()
            if not ok:
                break
            frames.append(frame)
        assert len(frames) == 90 and frames[0].shape == (240, 432, 3), len(frames)
        time.sleep(0.5)
"""


def test_bad_argument_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["models", "--frames", "0"])
    assert exc.value.code == 2


@pytest.mark.slow
def test_speed_closed_loop_prints_both_tables(capsys):
    assert main(["closed-loop", "--steps", "5", "--episodes", "1",
                     "--resolution", "small"]) == 0
    out = capsys.readouterr().out
    rows = {line.split("  ")[0] for line in out.splitlines()}
    assert {f"ReactiveAvoid({name})" for name in models.available()} <= rows
    assert "share of the time in the environment's step" in out
    assert "closed-loop episodes" in out and "the environment alone" in out
    assert "Start-up before the timing" in out  # the pools warmed, outside the timing


@pytest.mark.slow
def test_speed_dataset_prints_its_table(capsys):
    assert main(["dataset", "--scenarios", "StationaryApproach", "--episodes", "1",
                 "--resolution", "32x48", "--workers", "1", "--repeat", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].split()[:2] == ["scenario", "frames"]
    assert lines[2].split()[0] == "StationaryApproach"
    assert lines[-1].startswith("Start-up before each timing")  # apart from the timing


@pytest.mark.slow
def test_speed_models_prints_every_model(tmp_path):
    published = tmp_path / "Harmonizing motion and contrast vision.py"
    published.write_text(FAKE_PUBLISHED)
    # in a subprocess: the benchmark pins its process to one core
    cmd = [*SPEED, "models", "--height", "24",
           "--width", "32", "--frames", "4", "--streams", "2", "--markdown",
           "--published", str(published)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, timeout=600,
                         cwd=ROOT).stdout
    tables = out.split("\n\n")
    against = [line for line in tables[-1].splitlines() if line.startswith("| ")]
    assert against[0].startswith("| model | streaming fps at 240x432 | published Python LGMD")
    theirs, ratio, verdict = (c.strip() for c in against[1].split("|")[3:6])
    assert 0 < float(theirs) <= 180  # 90 frames in half a second and the reading
    assert ratio == f"{float(against[1].split('|')[2].replace(',', '')) / float(theirs):.0f}x"
    assert verdict == "not met"  # under 200x by far: no model streams at 36,000 frames/s
    rows = [line for line in tables[0].splitlines() if line.startswith("| ")]
    assert rows[0].startswith("| model | streaming fps")
    assert [r.split("|")[1].strip() for r in rows[1:]] == models.available()
    feedback = rows[1].split("|")
    assert float(feedback[2].replace(",", "")) > 0 and feedback[5].strip().endswith("x")
    # each row's target and its verdict in the same run: the feedback LGMD's own
    assert feedback[6].strip() in ("2,000: met", "2,000: not met")
    assert rows[2].split("|")[6].strip() in ("500: met", "500: not met")


def test_speed_stabilize_prints_every_front_end():
    """In a process of its own: the benchmark pins itself to one core."""
    run = subprocess.run([*SPEED, "stabilize",
                          "--height", "24", "--width", "32", "--frames", "2", "--markdown"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert "| image: rotation fit (ImageRotation.update) |" in run.stdout
    assert "| one warp of the previous frame (cv2.warpPerspective) |" in run.stdout
    rows = [line.split("|") for line in run.stdout.splitlines()
            if line.split("|")[1:2] in ([f" {name} "] for name in models.available())]
    assert len(rows) == len(models.available())
    for row in rows:  # the video preset's cost over the bare model's, and its verdict
        ratio = float(row[7].strip().removesuffix("x"))
        assert ratio > 0 and row[8].strip() == ("met" if ratio <= 2 else "not met")


@pytest.mark.slow
def test_speed_train_reports_each_row_against_the_bare_vec_env(capsys):
    from scripts.speed import train as speed_training

    assert main(["train", "--env", ENV, "--resolution", "small", "--steps", "64",
                     "--envs", "1", "--markdown"]) == 0
    table = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ")]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table[1:]]
    assert [r[0] for r in rows] == [f"{a}/{o}" for a, o, _ in speed_training.ROWS]
    assert rows[0][1] == "n_steps=32" and rows[3][1] == "train_freq=8, gradient_steps=8"
    for row in rows:
        bare, training, ratio = (float(row[i]) for i in (2, 3, 4))
        assert bare > 0 and training > 0
        assert ratio == pytest.approx(training / bare, abs=0.01 + 0.01 * ratio)
        assert row[5] == "-"  # the target is for 2 environments


def test_speed_envs_renders_again_the_views_the_steps_left():
    """`python -m scripts.speed envs`'s bare render is of each step's own view: the frame
    rendered again after a step is the step's frame."""
    from scripts.speed import envs as speed_envs

    env = gym.make("lgmd_sim/HandheldApproach-v0", resolution="small")
    world = env.unwrapped.world
    seen, again = [], []
    render = world.render_camera

    def recording(out):
        seen.append(world.rgb.copy())
        again.append(render(out).copy())
        return again[-1]

    world.render_camera = recording
    try:
        steps, renders = speed_envs._steps_and_renders_per_s(env, 5)
    finally:
        env.close()
    assert steps > 0 and renders > 0 and len(again) == 5
    assert all(np.array_equal(a, b) for a, b in zip(seen, again, strict=True))
