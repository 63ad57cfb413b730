"""The runnable examples (examples/), run as a user runs them: each script from the
repository's root with an output folder, the worked plug-in through the checker, and the
commands of the guides that ship them (docs/guides/own-detector.md, scaling.md); what
each wrote is checked."""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from protocols import tiny_protocol

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ("dataset_loop.py", "train.py", "ray_benchmark.py")
GUIDES = ROOT / "docs" / "guides"


def _run(command: str | list[str], cwd: Path = ROOT, **env: str
         ) -> subprocess.CompletedProcess:
    """`command` (a list, or a bash script) run as a user would, with this Python's
    `lgmd-sim` and `python` first on PATH; it must exit 0."""
    environ = {**os.environ, "HF_HUB_OFFLINE": "1", **env,
               "PATH": os.pathsep.join([str(Path(sys.executable).parent),
                                        os.environ.get("PATH", "")])}
    args = ["bash", "-euc", command] if isinstance(command, str) else command
    done = subprocess.run(args, cwd=cwd, env=environ, capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, f"{command}\n{done.stdout}\n{done.stderr}"
    return done


def _example(script: str, *args: str) -> subprocess.CompletedProcess:
    return _run([sys.executable, f"examples/{script}", *args])


def _refused(script: str, *args: str) -> str:
    """The error `script` refuses `args` with: one line, exit status 2, no traceback."""
    done = subprocess.run([sys.executable, f"examples/{script}", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2 and done.stdout == "", done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
    return done.stderr


def _bash_blocks(page: Path) -> list[list[str]]:
    """The command lines of each ```bash block of a page."""
    return [block.strip().splitlines() for block in
            re.findall(r"^```bash\n(.*?)^```", page.read_text(), re.S | re.M)]


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_example_says_what_it_does_and_where_it_writes(script):
    out = _example(script, "--help").stdout
    assert out.startswith(f"usage: {script}") and "--out OUT" in out
    first = (ROOT / "examples" / script).read_text().split('"""')[1].split("\n\n")[0]
    assert " ".join(first.split())[:40] in " ".join(out.split())  # the docstring's summary


def test_the_plug_in_example_has_a_help_that_says_how_to_use_it():
    out = _example("eta_lgmd.py", "--help").stdout
    assert out.startswith("usage: eta_lgmd.py") and "spec, eta_lgmd:EtaLGMD," in out
    assert "PYTHONPATH=examples lgmd-sim models --check eta_lgmd:EtaLGMD\n" in out
    done = _example("eta_lgmd.py")  # run without options it does nothing, as before
    assert (done.stdout, done.stderr) == ("", "")


@pytest.mark.parametrize("script", SCRIPTS)
def test_an_out_that_is_a_file_is_one_line(tmp_path, script):
    out = tmp_path / "out"
    out.write_text("kept")
    assert _refused(script, "--out", str(out)) == (
        f"{script}: error: output folder {out} is a file, not a folder\n")
    assert out.read_text() == "kept"


@pytest.mark.parametrize("option, value", [("--episodes", "0"), ("--workers", "0"),
                                           ("--jitter", "x")])
def test_a_bad_option_of_the_dataset_loop_is_one_line_and_makes_no_folder(
        tmp_path, option, value):
    out = tmp_path / "out"
    assert option in _refused("dataset_loop.py", "--out", str(out), option, value)
    assert not out.exists()


def test_the_training_example_refuses_its_seeds_before_training(tmp_path):
    out = tmp_path / "out"
    assert _refused("train.py", "--out", str(out), "--seeds", "0") == (
        "train.py: error: --seeds must be an integer >= 1, got 0\n")
    assert not out.exists()  # no policy trained first


@pytest.mark.slow
def test_the_dataset_loop_reads_the_same_frames_three_ways(tmp_path):
    for module in ("pyarrow", "datasets", "av"):
        pytest.importorskip(module)
    from lgmd_sim import data
    from lgmd_sim.data.verify import verify

    out = tmp_path / "out"
    printed = _example("dataset_loop.py", "--out", str(out)).stdout
    ds = data.open(out / "dataset")
    assert verify(out / "dataset")[0] == []
    frames = ds.info["total_frames"]
    assert len(ds) == 4 and {ep.outcome for ep in ds} == {"collision", "near_miss"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["lgmd_sim"]["episodes"] == 4 and summary["lgmd_sim"]["frames"] == frames
    # every 8-frame window, 4 frames apart, of each episode once
    assert summary["lgmd_sim"]["windows"] == sum((ep.length - 8) // 4 + 1 for ep in ds)
    assert summary["datasets"]["rows"] == frames and summary["datasets"]["episodes"] == 4
    under = sum(int((ep.labels["threat_ttc"].to_numpy() < 1.0).sum()) for ep in ds)
    assert summary["datasets"]["under_1s"] == under > 0
    assert summary["lerobot"] == {"frames": frames, "decoded": ds[0].length}
    assert (out / "lerobot" / "meta" / "info.json").is_file()
    assert printed.count("first alarm at frame") == 4


@pytest.mark.slow  # PPO's few hundred steps and the evaluation: about a minute
def test_the_training_example_trains_and_evaluates_a_policy(tmp_path):
    pytest.importorskip("stable_baselines3")
    out = tmp_path / "out"
    _example("train.py", "--out", str(out))
    policy = json.loads((out / "policy" / "policy.json").read_text())
    assert policy["config"]["model"] == "feedback" and (out / "policy" / "policy.npz").is_file()
    rows = list(csv.DictReader((out / "eval" / "summary.csv").open()))
    assert sorted(r["controller"] for r in rows) == ["oracle", "policy", "straight"]
    assert all(r["episodes"] == "1" for r in rows)
    assert "| policy: policy |" in (out / "eval" / "eval.md").read_text()


@pytest.mark.slow  # a Ray instance started, and the benchmark twice: a minute or two
def test_the_ray_example_gives_the_rows_of_a_local_run(tmp_path):
    pytest.importorskip("ray")
    out = tmp_path / "out"
    printed = _example("ray_benchmark.py", "--out", str(out), "--compare").stdout
    assert "the same 3 rows in this process as on Ray" in printed
    for where in ("ray", "local"):
        rows = list(csv.DictReader((out / where / "summary.csv").open()))
        assert [r["episodes"] for r in rows] == ["2"] * 3


@pytest.mark.slow  # a clip, its detection, a calibrated benchmark of a tiny protocol
def test_the_own_detector_guide_runs_as_written(tmp_path):
    """The guide's five-minute block, line for line, from a folder holding examples/ (the
    smoke run, the benchmark and the leaderboard on a tiny protocol: the real one takes 10
    minutes), then the first lines of "Make it yours"."""
    tiny = tiny_protocol(tmp_path, budget="budget = 2", seeds="seeds = 1")
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    five, yours = _bash_blocks(GUIDES / "own-detector.md")[:2]
    tiny_lines = [line.replace(" --", f" --protocol {tiny} --workers 1 --", 1)
                  if line.startswith("lgmd-sim benchmark ") else
                  f"{line} --protocol {tiny}" if line.startswith("lgmd-sim leaderboard ")
                  else line for line in five]
    assert tiny_lines != five
    printed = _run("\n".join(tiny_lines), cwd=tmp_path).stdout
    collision = re.search(r"--collision-frame (\d+)", "\n".join(five)).group(1)
    assert f"collision at frame {collision}\n" in printed  # the frame the guide passes on
    assert {p.name for p in (tmp_path / "detect-out").iterdir()} == {
        "clip.csv", "clip.json", "clip.png"}
    result = json.loads(
        (tmp_path / "runs" / "eta_lgmd_EtaLGMD-robot-image" / "result.json").read_text())
    assert result["entry"]["label"] == "eta_lgmd:EtaLGMD/robot-image"
    assert "`eta_lgmd:EtaLGMD/robot-image`" in (tmp_path / "runs" / "leaderboard.md").read_text()
    # Make it yours: the copy, under its own name, passes the checker as it stands
    assert yours[2] == "lgmd-sim models --check looming:EtaLGMD"
    printed = _run("\n".join(yours[:3]), cwd=tmp_path).stdout
    assert printed.startswith("looming:EtaLGMD: passes 10 checks")


@pytest.mark.slow  # Ray started twice
def test_the_scaling_guide_commands_run(tmp_path):
    pytest.importorskip("ray")
    pytest.importorskip("pyarrow")
    (commands,) = [b for b in _bash_blocks(GUIDES / "scaling.md") if b[0].startswith("lgmd")]
    _run("\n".join(commands), cwd=tmp_path)
    assert len(list(csv.DictReader((tmp_path / "ray-bench" / "summary.csv").open()))) == 3
    info = json.loads((tmp_path / "ray-dataset" / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 4
