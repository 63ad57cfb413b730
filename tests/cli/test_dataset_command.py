"""`lgmd-sim dataset`: bad input refused before any episode; a killed run, a killed worker
and a full disk lose at most the episodes in flight, and re-running resumes to the same
bytes."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lgmd_sim.cli import main
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.data import layout
from lgmd_sim.data.generate import GenerateConfig, _complete, generate

from datasets_tiny import ARGS, CONFIG, tree

pytest.importorskip("pyarrow")
LGMD_SIM = [sys.executable, "-m", "lgmd_sim.cli", "dataset", "generate"]


@pytest.mark.parametrize(("args", "named"), [
    (["--scenarios", "Nowhere"], "unknown scenario(s) 'Nowhere'"),
    (["--controller", "autopilot"], "unknown controller 'autopilot'"),
    (["--models", "feedback,lgmd9"], "unknown model(s) 'lgmd9'"),
    (["--noise", "gaussian:0.005,fog:1"], "unknown noise 'fog'"),
    (["--noise", "gaussian"], "bad noise 'gaussian'"),
    (["--jitter", "0,9"], "--jitter must hold jitter levels in [0, 5], got '9'"),
    (["--jitter", "0,x"], "--jitter must hold jitter levels in [0, 5], got 'x'"),
    (["--set", "warp=3"], "unknown parameter(s) warp"),
    (["--set", "jitter=3"], "overrides sets jitter, a field of the dataset's own"),
])
def test_bad_input_is_one_line_naming_it_before_any_episode(tmp_path, capsys, args, named):
    out = tmp_path / "ds"
    assert main(["dataset", "generate", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and named in err, err
    assert not out.exists()


def test_episodes_below_one_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["dataset", "generate", "--episodes", "0", "--out", str(tmp_path)])
    assert exc.value.code == 2 and "--episodes: must be an integer >= 1, got 0" in \
        capsys.readouterr().err


def test_another_configuration_or_foreign_folder_is_refused(tmp_path, capsys):
    small = ["--scenarios", "StationaryApproach", "--jitter", "0", "--episodes", "1",
             "--resolution", "32x48", "--set", "time_limit=0.2", "--no-progress"]
    out = tmp_path / "ds"
    assert main(["dataset", "generate", "--out", str(out), "--workers", "1", *small]) == 0
    capsys.readouterr()
    assert main(["dataset", "generate", "--out", str(out), *small, "--jitter", "0,1"]) == 2
    err = capsys.readouterr().err
    assert "another configuration: jitter is 0 there, 0,1 here" in err and err.count("\n") == 1
    config = json.loads((out / layout.CONFIG).read_text())  # as if the scenario file changed
    config["resolved"]["scenarios"]["StationaryApproach"]["mover_speed"] = 9.0
    (out / layout.CONFIG).write_text(json.dumps(config))
    assert main(["dataset", "generate", "--out", str(out), *small]) == 2
    assert ("resolved.scenarios.StationaryApproach.mover_speed is 9.0 there, 2.0 here"
            in capsys.readouterr().err)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    assert main(["dataset", "generate", "--out", str(tmp_path / "other"), *small]) == 2
    assert "not empty and holds no lgmd-sim dataset" in capsys.readouterr().err
    assert main(["dataset", "verify", str(tmp_path / "other")]) == 1


def _wait_for(path: Path, proc: subprocess.Popen, timeout: float = 120) -> None:
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.02)


@pytest.mark.slow
def test_killed_run_resumes_to_the_same_bytes(tmp_path):
    out = tmp_path / "ds"
    proc = subprocess.Popen([*LGMD_SIM, *ARGS, "--out", str(out), "--workers", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)
    _wait_for(out / layout.data_path(0), proc)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (out / layout.INFO).exists()  # killed mid-way
    specs = CONFIG.specs()
    done = [s.index for s in specs if _complete(out, s) is not None]
    assert 0 in done and len(done) < len(specs)
    # What else a kill can leave: a video without its data file, a temporary of a dead
    # process; both are removed and the episode redone.
    last = specs[-1]
    shutil.copy(out / layout.video_path(0, "huffyuv"), out / layout.video_path(last.index,
                                                                               "huffyuv"))
    stale = out / layout.data_path(last.index)
    (stale.parent / f".{stale.name}.999999999-abcd.partial.parquet").write_bytes(b"torn")
    result = subprocess.run([*LGMD_SIM, *ARGS, "--out", str(out)], capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert f"{len(done)} kept" in result.stdout
    clean = tmp_path / "clean"
    generate(CONFIG, clean, RunOptions(workers=1, progress=False))
    assert tree(out) == tree(clean)


def _workers(pid: int) -> list[int]:
    """The spawn pool's worker processes among the children of `pid`."""
    children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    return [int(c) for c in children
            if b"spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes()]


@pytest.mark.slow
def test_killed_worker_ends_the_run_in_one_line_and_keeps_finished_episodes(tmp_path):
    out = tmp_path / "ds"
    args = [*ARGS, "--out", str(out), "--workers", "2"]
    args[args.index("--episodes") + 1] = "4"
    proc = subprocess.Popen([*LGMD_SIM, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    _wait_for(out / layout.data_path(0), proc)
    os.kill(_workers(proc.pid)[0], signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    assert err.count("\n") == 1 and "worker process died" in err and "resume" in err, err
    assert (out / layout.data_path(0)).exists()
    result = subprocess.run([*LGMD_SIM, *args], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert main(["dataset", "verify", str(out)]) == 0


@pytest.fixture
def small_disk(tmp_path):
    mount = tmp_path / "disk"
    mount.mkdir()
    try:
        subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)],
                       check=True, capture_output=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        pytest.skip(f"cannot mount a small tmpfs here (needs root): {exc}")
    yield mount
    subprocess.run(["umount", str(mount)], check=False)


@pytest.mark.slow
def test_full_disk_is_one_line_naming_the_folder_and_leaves_no_corrupt_episode(small_disk):
    out = small_disk / "ds"
    result = subprocess.run([*LGMD_SIM, "--scenarios", "HandheldApproach", "--jitter", "0,1",
                             "--episodes", "3", "--resolution", "64x96", "--workers", "1",
                             "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1, result.stderr
    assert f"no space left on the device of {out}" in result.stderr
    assert [p for p in out.rglob("*") if ".partial" in p.name] == []
    assert not (out / layout.INFO).exists()
    config = GenerateConfig(("HandheldApproach",), (0.0, 1.0), 3, (64, 96))
    on_disk = [s for s in config.specs() if (out / layout.video_path(s.index, "huffyuv"))
               .exists() or (out / layout.data_path(s.index)).exists()]
    assert on_disk and all(_complete(out, s) is not None for s in on_disk)
