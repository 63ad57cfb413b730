"""Nothing half-written on a full disk: every command that writes (record, demo, detect,
dataset generate, bench closed-loop) fails in one line naming what it could not write,
leaves no file under a final name that is not complete and no temporary, and a rerun
after freeing space completes. The disk is a small tmpfs, mounted in a private mount
namespace (``unshare -rm``); the cases skip where that is not permitted. Videos are also
checked where OpenCV's writer drops frames without a full disk (a file size limit)."""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from lgmd_sim.apps import demo
from lgmd_sim.data import layout
from lgmd_sim.signals.video import VideoReader, encoder, video_writer

LGMD_SIM = [sys.executable, "-m", "lgmd_sim.cli"]
SMALL_DATASET = ["--scenarios", "StationaryApproach", "--jitter", "0", "--episodes", "2",
                 "--resolution", "small", "--set", "time_limit=0.5", "--no-progress",
                 "--workers", "1"]
SMALL_BENCH = ["--scenarios", "StationaryApproach", "--jitter", "0", "--controllers",
               "straight,reactive", "--models", "lgmd1", "--seeds", "2", "--resolution",
               "small", "--no-progress", "--workers", "1"]


@dataclass
class Run:
    rc: int
    err: str
    files: set[str]  # what the disk holds afterwards (relative paths), the filler aside


def _mount_error() -> str | None:
    if shutil.which("unshare") is None:
        return "no unshare command"
    probe = subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs tmpfs /mnt"],
                           capture_output=True, text=True, timeout=30)
    return probe.stderr.strip() or f"exit {probe.returncode}" if probe.returncode else None


@pytest.fixture(scope="module")
def full_disk():
    """Run commands with a small tmpfs at DISK, filled to `free_kb` free; report each
    command's exit status, stderr and what the disk then holds."""
    problem = _mount_error()
    if problem is not None:
        pytest.skip(f"cannot mount a tmpfs in a user namespace (unshare -rm): {problem}")

    def run(disk: Path, *commands: list[str], size_kb: int = 1024, free_kb: int = 100,
            env: dict[str, str] | None = None) -> list[Run]:
        disk.mkdir(parents=True, exist_ok=True)
        report = disk.parent / f"{disk.name}-report"
        report.mkdir()
        lines = [f'mount -t tmpfs -o size={size_kb}k tmpfs "{disk}" || exit 97',
                 f'head -c {size_kb - free_kb}k /dev/zero > "{disk}/.fill"']
        for i, command in enumerate(commands):
            if command == ["free"]:
                lines.append(f'rm "{disk}/.fill"')
            lines.append(f'{subprocess.list2cmdline(command)} >/dev/null 2>"{report}/{i}.err"; '
                         f'echo $? > "{report}/{i}.rc"')
            lines.append(f'(cd "{disk}" && find . -type f ! -name .fill) > "{report}/{i}.files"')
        proc = subprocess.run(["unshare", "-rm", "sh", "-c", "\n".join(lines)], env=env,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode != 97, proc.stderr
        return [Run(int((report / f"{i}.rc").read_text()), (report / f"{i}.err").read_text(),
                    {f.removeprefix("./") for f in (report / f"{i}.files").read_text().split()})
                for i, command in enumerate(commands) if command != ["free"]]

    return run


def _one_line(run: Run, *named: str) -> None:
    assert run.rc == 2, run.err
    assert run.err.count("\n") == 1 and "error:" in run.err and "Traceback" not in run.err, \
        run.err
    # the output as the user named it: no errno, no temporary name
    assert "[Errno" not in run.err and ".partial" not in run.err, run.err
    for text in named:
        assert text in run.err, run.err


def _no_temporaries(files: set[str]) -> None:
    assert not [f for f in files if ".partial" in f], files


# --- record, demo, detect -----------------------------------------------------------------


@pytest.mark.slow
def test_record_on_a_full_disk_fails_in_one_line_and_leaves_no_video(full_disk, tmp_path):
    disk = tmp_path / "disk"
    (run,) = full_disk(disk, [*LGMD_SIM, "record", "PassBy", str(disk / "r.avi"),
                              "--resolution", "small", "--no-progress"], free_kb=60)
    _one_line(run, f"{disk / 'r.avi'}: cannot write video: no space left on device",
              "of 181 frames")
    assert run.files == set()


SMALL_DEMO = ["demo", "--resolution", "small", "--models", "feedback/paper",
              "--avoid-resolution", "small", "--avoid-seed", "3"]


@pytest.mark.slow
def test_demo_on_a_full_disk_leaves_no_video_or_figure(full_disk, tmp_path):
    disk = tmp_path / "disk"
    (run,) = full_disk(disk, [*LGMD_SIM, *SMALL_DEMO, "--out", str(disk / "d")], free_kb=60)
    _one_line(run, str(disk / "d" / "demo.mp4"), "no space left on device")
    assert run.files == set()


@pytest.mark.slow
def test_demo_whose_avoiding_video_does_not_fit_leaves_none_of_its_files(full_disk, tmp_path):
    """The open-loop files (about 1.8 MB at 64 x 64, shown three times larger) fit, the
    avoiding video (about 3.5 MB more) does not: the set is written whole or not at all."""
    disk = tmp_path / "disk"
    (run,) = full_disk(disk, [*LGMD_SIM, *SMALL_DEMO, "--out", str(disk / "d")],
                       size_kb=8192, free_kb=2600)
    _one_line(run, str(disk / "d" / "avoid.mp4"), "no space left on device")
    assert run.files == set()


def test_detect_on_a_full_disk_writes_no_partial_set(full_disk, tmp_path):
    clip = tmp_path / "clip.avi"
    frames = np.random.default_rng(0).integers(0, 255, (12, 32, 48, 3), np.uint8)
    with video_writer(clip, 30, (32, 48)) as write:
        for rgb in frames:
            write(rgb)
    disk = tmp_path / "disk"
    (run,) = full_disk(disk, [*LGMD_SIM, "detect", str(clip), "--models", "lgmd1", "--out",
                              str(disk / "out"), "--no-progress"], free_kb=40)
    _one_line(run, str(disk / "out" / "clip."), "No space left on device")
    assert run.files == set()


# --- dataset generate, bench closed-loop --------------------------------------------------


@pytest.mark.slow
def test_dataset_on_a_full_disk_keeps_complete_episodes_and_resumes(full_disk, tmp_path):
    disk = tmp_path / "disk"
    generate = [*LGMD_SIM, "dataset", "generate", "--out", str(disk / "ds"), *SMALL_DATASET]
    full, resumed, verified = full_disk(disk, generate, ["free"], generate,
                                        [*LGMD_SIM, "dataset", "verify", str(disk / "ds")],
                                        free_kb=120)
    _one_line(full, f"no space left on the device of {disk / 'ds'}")
    _no_temporaries(full.files)
    videos = {f for f in full.files if f.endswith(".avi")}
    data = {f for f in full.files if f.startswith("ds/data/")}
    # an episode is complete (its data file written last) or absent; no manifest yet
    assert len(data) <= len(videos) <= 2 and f"ds/{layout.INFO}" not in full.files
    assert resumed.rc == 0 and verified.rc == 0, resumed.err + verified.err


def test_dataset_with_a_full_temporary_folder_stores_no_broken_episode(full_disk, tmp_path):
    out = tmp_path / "ds"
    disk = tmp_path / "disk"
    (run,) = full_disk(disk, [*LGMD_SIM, "dataset", "generate", "--out", str(out),
                              *SMALL_DATASET], free_kb=30,
                       env={**os.environ, "TMPDIR": str(disk)})
    # the episode's video is encoded there first: that is the full device, not the dataset's
    _one_line(run, f"no space left on the device of {disk}", f"kept in {out}")
    assert not [p for p in out.rglob("*") if p.suffix in (".avi", ".parquet")], \
        "a truncated episode was stored"
    assert run.files == set()  # the episode's temporary folder went too


def test_dataset_named_like_the_temporary_folder_blames_the_full_one(full_disk, tmp_path):
    """A short relative DIR ("ep") is part of the episode's temporary folder's name
    (lgmd-sim-episode-...): the full device is still told by the path of what failed."""
    disk = tmp_path / "disk"
    (run,) = full_disk(disk, ["env", "-C", str(tmp_path), *LGMD_SIM, "dataset", "generate",
                              "--out", "ep", *SMALL_DATASET], free_kb=30,
                       env={**os.environ, "TMPDIR": str(disk)})
    _one_line(run, f"no space left on the device of {disk}", "kept in ep")
    assert run.files == set()


@pytest.mark.slow
@pytest.mark.parametrize("free_kb", [8, 40])  # full among the records; at the figures
def test_bench_on_a_full_disk_keeps_its_records_and_resumes(full_disk, tmp_path, free_kb):
    disk = tmp_path / "disk"
    bench = [*LGMD_SIM, "bench", "closed-loop", "--out", str(disk / "b"), *SMALL_BENCH]
    full, resumed = full_disk(disk, bench, ["free"], [*bench, "--resume"], free_kb=free_kb)
    _one_line(full, str(disk / "b"))
    _no_temporaries(full.files)
    assert "b/episodes.csv" not in full.files and "b/summary.csv" not in full.files
    assert resumed.rc == 0, resumed.err
    assert {"b/episodes.csv", "b/summary.csv", "b/summary.md"} <= resumed.files


# --- the video check itself ---------------------------------------------------------------


_WRITE_CLIP = """
import sys
import numpy as np
from lgmd_sim.signals.video import video_writer
frames = np.random.default_rng(0).integers(0, 255, (40, 48, 64, 3), np.uint8)
with video_writer(sys.argv[1], 30, (48, 64)) as write:
    for rgb in frames:
        write(rgb)
"""


def _limit_file_size() -> None:
    # writes past the limit fail with EFBIG (SIGXFSZ ignored), as on a full disk, with the
    # disk itself far from full
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))


@pytest.mark.parametrize("suffix", [".avi", ".mp4"])
def test_a_video_missing_frames_is_refused_and_not_left(tmp_path, suffix):
    target = tmp_path / f"clip{suffix}"
    proc = subprocess.run([sys.executable, "-c", _WRITE_CLIP, str(target)],
                          preexec_fn=_limit_file_size, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    # the OSError's filename: the file that could not be written, at the end of the line
    assert last.startswith("OSError: [Errno") and "cannot write video: " in last, proc.stderr
    assert last.endswith(f"of 40 frames written: '{target}'"), proc.stderr
    assert "WARN" not in proc.stderr  # OpenCV's per-frame warnings are ours to report
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fourcc,suffix", [("FFV1", ".mkv"), ("FFV1", ".avi"),
                                           ("HFYU", ".avi"), ("mp4v", ".mp4")])
@pytest.mark.parametrize("n", [1, 2, 13])
def test_a_complete_video_passes_the_check(tmp_path, fourcc, suffix, n):
    path = tmp_path / f"clip{suffix}"
    frames = np.random.default_rng(n).integers(0, 255, (n, 24, 32, 3), np.uint8)
    with encoder(path, fourcc, 30, (24, 32)) as write:
        for rgb in frames:
            write(rgb)
    assert len(list(VideoReader(path))) == n


def test_frames_are_encoded_as_written_while_the_caller_reuses_its_buffer(tmp_path):
    from lgmd_sim.signals.video import ENCODER_QUEUE

    path = tmp_path / "clip.mkv"  # FFV1: lossless, so the frames read back exactly
    frames = np.random.default_rng(0).integers(0, 255, (3 * ENCODER_QUEUE, 24, 32, 3),
                                               np.uint8)
    buffer = np.empty_like(frames[0])
    with encoder(path, "FFV1", 30, (24, 32)) as write:
        for rgb in frames:
            buffer[:] = rgb
            write(buffer)  # the encoder's thread may not have encoded it yet
            buffer[:] = 0
    np.testing.assert_array_equal(np.stack(list(VideoReader(path))), frames)


# --- demo.png: whose threshold ------------------------------------------------------------


def test_demo_summary_says_whose_threshold_each_line_is(tmp_path, monkeypatch):
    import lgmd_sim.core.plots

    made = []
    figure = lgmd_sim.core.plots.figure
    monkeypatch.setattr(lgmd_sim.core.plots, "figure", lambda **kw: made.append(figure(**kw))
                        or made[-1])
    # a threshold of its own (0.895), and one that two detectors share (0.8)
    detectors = ["feedback/calibrated-image", "feedback/paper", "lgmd1/published"]
    ep = demo.drive(0, 1.0, detectors, resolution="small")
    assert sorted(ep.thresholds.values()) == [0.8, 0.8, 0.895]
    demo.write_summary(ep, tmp_path / "demo.png", "test")
    (fig,) = made
    potentials = next(ax for ax in fig.axes if ax.get_ylabel() == "membrane potential")
    legend = [t.get_text() for t in potentials.get_legend().get_texts()]
    for name in detectors:
        (line,) = [ln for ln in potentials.get_lines() if "threshold" in ln.get_label()
                   and ln.get_label().startswith(f"threshold of {name}:")]
        assert line.get_label() in legend
        assert np.allclose(line.get_ydata(), ep.thresholds[name])
        assert np.allclose(to_rgb(line.get_color()),
                           to_rgb(lgmd_sim.core.plots.model_style(name)["color"]))
    # the two lines on one threshold take turns: both colours show along it
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())[..., :3] / 255
    x0, y = potentials.transData.transform((0, 0.8))
    x1, _ = potentials.transData.transform((len(ep.frames) / ep.fps, 0.8))
    row = pixels[pixels.shape[0] - round(y), round(x0):round(x1)]
    for name in ("feedback/paper", "lgmd1/published"):
        colour = to_rgb(lgmd_sim.core.plots.model_style(name)["color"])
        assert (np.abs(row - colour).max(axis=1) < 0.1).mean() > 0.2, name


def test_a_scratch_folder_a_killed_process_left_goes_with_the_next_one(tmp_path, monkeypatch):
    """An episode's video is encoded in a scratch folder that a SIGKILLed run cannot
    remove: the next run removes it (its process is gone), not a running one's."""
    import tempfile

    from lgmd_sim.core.fileio import scratch_folder

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = tmp_path / f".lgmd-sim-episode.{dead.pid}-ab.partial"
    live = tmp_path / f".lgmd-sim-episode.{os.getpid()}-cd.partial"
    for folder in (stale, live):
        (folder / "episode.avi").parent.mkdir()
        (folder / "episode.avi").write_bytes(b"x")
    with scratch_folder("lgmd-sim-episode") as scratch:
        assert scratch.parent == tmp_path and scratch.is_dir()
    assert not stale.exists() and live.is_dir() and not scratch.exists()
