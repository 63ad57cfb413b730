"""LeRobot: the `index` column and meta/stats.json of our own datasets, and
`lgmd-sim dataset export --format lerobot` (H.264 MP4 videos, LeRobot's tables), checked
against the format as LeRobot's dataset class reads it."""

from __future__ import annotations

import errno
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import data
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.data import layout
from lgmd_sim.data.card import configs
from lgmd_sim.data.generate import GenerateConfig, generate

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

#: Two tasks, four short episodes: enough for the index to run across episodes.
CONFIG = GenerateConfig(("HandheldApproach", "PassBy"), (0.0,), 2, (32, 48),
                        overrides={"time_limit": 0.4})
QUANTILES = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("lerobot") / "tiny"
    generate(CONFIG, out, RunOptions(workers=1, progress=False))
    return out


@pytest.fixture(scope="module")
def exported(dataset, tmp_path_factory) -> Path:
    from lgmd_sim.data.export import ExportConfig, export

    pytest.importorskip("av")
    dest = tmp_path_factory.mktemp("exports") / "tiny-lerobot"
    export(ExportConfig(dataset, dest))
    return dest


def test_data_files_carry_the_global_index(dataset):
    ds = data.open(dataset)
    for ep in ds:
        labels = ep.labels
        start = ep.meta["dataset_from_index"]
        assert labels["index"].to_pylist() == list(range(start, start + ep.length))
    assert ds.labels(["index"])["index"].to_pylist() == list(range(ds.info["total_frames"]))


def test_stats_json_holds_lerobots_statistics_of_every_label(dataset):
    stats = json.loads((dataset / "meta" / "stats.json").read_text())
    labels = data.open(dataset).labels()
    assert set(stats) == set(labels.column_names)
    n = labels.num_rows
    state = np.asarray(labels["observation.state"].to_pylist(), np.float64)
    s = stats["observation.state"]
    assert s["count"] == [n]
    np.testing.assert_allclose(s["mean"], state.mean(axis=0), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(s["std"], state.std(axis=0), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(s["min"], state.min(axis=0), rtol=1e-6)
    for key, q in QUANTILES.items():
        np.testing.assert_allclose(s[key], np.quantile(state, q, axis=0), rtol=1e-6, atol=1e-9)
    assert stats["index"]["max"] == [n - 1] and stats["episode_index"]["max"] == [3]
    # the last frame's action is NaN: statistics of the finite values, as a policy needs
    action = np.asarray(labels["action"].to_pylist(), np.float64)
    np.testing.assert_allclose(stats["action"]["mean"], np.nanmean(action, axis=0), rtol=1e-6)
    flags = labels["terminated"].to_numpy(zero_copy_only=False)
    assert stats["terminated"]["mean"] == pytest.approx([flags.mean()])  # bools as 0 and 1
    # a component without any finite value (no goal in these scenarios) has no statistics
    assert stats["observation.goal"]["mean"] == [None, None, None]


def test_resume_keeps_the_finished_episodes_and_the_same_bytes(dataset, tmp_path):
    again = tmp_path / "again"
    generate(CONFIG, again, RunOptions(workers=1, progress=False))
    before = {p: p.read_bytes() for p in (again / "data").rglob("*.parquet")}
    summary = generate(CONFIG, again, RunOptions(workers=1, progress=False))
    assert (summary.made, summary.kept) == (0, 4)
    assert {p: p.read_bytes() for p in (again / "data").rglob("*.parquet")} == before
    for rel in ("meta/stats.json", layout.data_path(3)):
        assert (again / rel).read_bytes() == (dataset / rel).read_bytes()


def test_export_writes_lerobots_layout(dataset, exported):
    info = json.loads((exported / "meta/info.json").read_text())
    source = data.open(dataset)
    assert info["codebase_version"] == "v3.0"
    assert info["total_episodes"] == 4 and info["total_frames"] == source.info["total_frames"]
    assert info["video_path"] == ("videos/{video_key}/chunk-{chunk_index:03d}/"
                                  "file-{file_index:03d}.mp4")
    camera = info["features"][layout.VIDEO_KEY]
    assert camera["dtype"] == "video" and camera["shape"] == [32, 48, 3]
    assert camera["info"]["video.codec"] == "h264"
    assert camera["info"]["video.pix_fmt"] == "yuv420p"
    episodes = pq.read_table(exported / "meta/episodes/chunk-000/file-000.parquet")
    for col in ("episode_index", "tasks", "length", "data/chunk_index", "data/file_index",
                "dataset_from_index", "dataset_to_index", "meta/episodes/chunk_index",
                "meta/episodes/file_index", f"videos/{layout.VIDEO_KEY}/chunk_index",
                f"videos/{layout.VIDEO_KEY}/file_index",
                f"videos/{layout.VIDEO_KEY}/from_timestamp",
                f"videos/{layout.VIDEO_KEY}/to_timestamp"):
        assert col in episodes.column_names, col
    assert episodes["video_codec"].to_pylist() == ["h264"] * 4
    for row in episodes.to_pylist():  # the checksums are the exported files'
        i = row["episode_index"]
        assert row["data/sha256"] == layout.sha256(exported / layout.data_path(i))
        video = exported / info["video_path"].format(video_key=layout.VIDEO_KEY,
                                                     chunk_index=0, file_index=i)
        assert row[f"videos/{layout.VIDEO_KEY}/sha256"] == layout.sha256(video)
    assert not list(exported.rglob("*.avi")) and not (exported / layout.CONFIG).exists()
    card = (exported / "README.md").read_text()
    # the labels' glob is the source's (layout.DATA_PATH's), and matches every data file;
    # the configuration is named after the exported label files, as `datasets` caches by name
    assert card.startswith(f"---\n{configs(episodes['data/sha256'].to_pylist())}")
    assert f"path: {layout.DATA_GLOB}\n" in card
    assert len(list(exported.glob(layout.DATA_GLOB))) == 4
    assert not list(exported.parent.glob(".*partial*"))  # no temporary left beside it
    umask = os.umask(0)
    os.umask(umask)
    assert exported.stat().st_mode & 0o777 == 0o777 & ~umask  # not mkdtemp's 0o700


def test_export_tasks_are_indexed_by_their_text(exported):
    pd = pytest.importorskip("pandas")

    tasks = pd.read_parquet(exported / "meta/tasks.parquet")
    # LeRobotDataset.__getitem__ names a frame's task by tasks.iloc[task_index].name
    assert tasks.index.name == "task"
    assert tasks.iloc[1].name.startswith("PassBy: ") and tasks.iloc[1]["task_index"] == 1


def test_exported_videos_are_h264_with_lerobots_timestamps(dataset, exported):
    import av

    ep = data.open(dataset)[2]
    video = exported / f"videos/{layout.VIDEO_KEY}/chunk-000/file-002.mp4"
    with av.open(str(video)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264" and stream.format.name == "yuv420p"
        decoded = [(float(f.pts * f.time_base), f.to_ndarray(format="rgb24"))
                   for f in container.decode(stream)]
    times = np.array([t for t, _ in decoded])
    # LeRobot finds a frame by its timestamp (tolerance 1e-4 s): frame_index / fps
    np.testing.assert_allclose(times, np.arange(ep.length) / ep.fps, atol=1e-4)
    frames = np.stack([f for _, f in decoded]).astype(np.int16)
    assert np.abs(frames - ep.frames()).mean() < 4  # lossy, but close


def test_export_stats_add_the_cameras_per_channel_statistics(dataset, exported):
    stats = json.loads((exported / "meta/stats.json").read_text())
    ours = json.loads((dataset / "meta/stats.json").read_text())
    assert {k: v for k, v in stats.items() if k != layout.VIDEO_KEY} == ours
    camera = stats[layout.VIDEO_KEY]
    frames = np.concatenate([ep.frames() for ep in data.open(dataset)]) / 255.0
    assert camera["count"] == [len(frames)]
    assert np.asarray(camera["mean"]).shape == (3, 1, 1)  # LeRobot's shape for images
    # statistics of the exported (decoded) frames: close to the source's
    np.testing.assert_allclose(np.ravel(camera["mean"]), frames.mean(axis=(0, 1, 2)), atol=0.02)
    np.testing.assert_allclose(np.ravel(camera["std"]), frames.std(axis=(0, 1, 2)), atol=0.02)
    assert all(0 <= v <= 1 for k in ("min", "max", "q50") for v in np.ravel(camera[k]))


def test_labels_load_as_lerobot_loads_them(exported):
    """LeRobotDataset loads data/ with `datasets`, its Features made from info.json's
    features as `get_hf_features_from_features` makes them: every column is declared,
    of its type."""
    datasets = pytest.importorskip("datasets")

    info = json.loads((exported / "meta/info.json").read_text())
    features = {}
    for key, ft in info["features"].items():
        if ft["dtype"] == "video":
            continue
        value = datasets.Value(dtype=ft["dtype"])
        features[key] = value if ft["shape"] == [1] else datasets.List(value,
                                                                       length=ft["shape"][0])
    features = datasets.Features(features)
    files = sorted(str(p) for p in (exported / "data").glob("*/*.parquet"))
    table = datasets.Dataset.from_parquet(files, features=features)
    assert len(table) == info["total_frames"]
    assert table["index"] == list(range(info["total_frames"]))
    # LeRobotDataset(episodes=[...]) casts the episodes' rows to the features, in order
    episode = pq.read_table(files[1]).cast(features.arrow_schema)
    assert episode["episode_index"].to_pylist() == [1] * episode.num_rows


def test_export_refuses_a_bad_source_or_an_existing_destination(dataset, tmp_path):
    from lgmd_sim.data.export import ExportConfig

    with pytest.raises(ValueError, match="not an lgmd-sim dataset"):
        ExportConfig(tmp_path, tmp_path / "out")
    (tmp_path / "taken").mkdir()
    with pytest.raises(ValueError, match=r"taken.*exists"):
        ExportConfig(dataset, tmp_path / "taken")
    with pytest.raises(ValueError, match="inside"):
        ExportConfig(dataset, dataset / "lerobot")
    with pytest.raises(ValueError, match=r"^codec must be one of"):
        ExportConfig(dataset, tmp_path / "out", codec="mjpeg")
    with pytest.raises(ValueError, match=r"^format must be one of"):
        ExportConfig(dataset, tmp_path / "out", format="rlds")


def test_a_failed_export_leaves_nothing(dataset, tmp_path, monkeypatch):
    from lgmd_sim.data import export as export_mod

    pytest.importorskip("av")
    calls = []

    def full(*args, **kwargs):
        if calls:
            raise OSError(errno.ENOSPC, "No space left on device")
        calls.append(1)
        return real(*args, **kwargs)

    real = export_mod._encode
    monkeypatch.setattr(export_mod, "_encode", full)
    with pytest.raises(OSError, match=r"no space left.*out"):
        export_mod.export(export_mod.ExportConfig(dataset, tmp_path / "out"))
    assert list(tmp_path.iterdir()) == []  # neither DEST nor its temporary folder


@pytest.mark.parametrize("name", ["out", "out.lerobot"])  # a dot: DEST has a suffix
def test_an_export_killed_outright_leaves_a_folder_the_next_one_removes(dataset, tmp_path,
                                                                         name):
    """A SIGKILLed export cannot remove its hidden temporary folder; the next export to
    the same DEST removes it (its process is gone), and leaves a running one's alone, and
    another DEST's."""
    import subprocess

    from lgmd_sim.data.export import ExportConfig, export

    pytest.importorskip("av")
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = tmp_path / f".{name}.{dead.pid}-x1.partial"
    live = tmp_path / f".{name}.{os.getpid()}-x2.partial"
    other = tmp_path / f".{name}.x.{dead.pid}-x3.partial"  # DEST {name}.x's
    for folder in (stale, live, other):
        (folder / "data").mkdir(parents=True)
    export(ExportConfig(dataset, tmp_path / name))
    assert not stale.exists() and live.is_dir() and other.is_dir()
    assert (tmp_path / name / layout.INFO).is_file()


def test_an_export_refuses_a_dest_made_meanwhile(dataset, tmp_path, monkeypatch):
    """DEST made (empty, which a rename would silently replace) while the export ran is
    left as it is, and the export's folder removed."""
    from lgmd_sim.data import export as export_mod

    pytest.importorskip("av")
    dest = tmp_path / "out"
    real = export_mod._write

    def write_then_race(root, *args):
        frames = real(root, *args)
        dest.mkdir()
        return frames

    monkeypatch.setattr(export_mod, "_write", write_then_race)
    with pytest.raises(OSError, match=rf"cannot export to {dest}: File exists"):
        export_mod.export(export_mod.ExportConfig(dataset, dest))
    assert list(tmp_path.iterdir()) == [dest] and list(dest.iterdir()) == []


def test_export_refuses_an_info_json_without_the_camera_in_one_line(dataset, tmp_path):
    from lgmd_sim.data.export import ExportConfig, export

    pytest.importorskip("av")
    source = Path(shutil.copytree(dataset, tmp_path / "source"))
    info = json.loads((source / layout.INFO).read_text())
    del info["features"][layout.VIDEO_KEY]
    (source / layout.INFO).write_text(json.dumps(info))
    with pytest.raises(ValueError) as exc:
        export(ExportConfig(source, tmp_path / "out"))
    assert str(source / layout.INFO) in str(exc.value) and layout.VIDEO_KEY in str(exc.value)
    assert "\n" not in str(exc.value) and not (tmp_path / "out").exists()


def test_a_dataset_made_before_the_index_column_resumes_and_gets_it(dataset, tmp_path):
    """Rerunning the command of a dataset made before the ``index`` column (data files
    without it, no meta/stats.json, info.json without its feature) adds it."""
    old = Path(shutil.copytree(dataset, tmp_path / "old"))
    for path in (old / "data").rglob("*.parquet"):
        table = pq.read_table(path)
        pq.write_table(table.drop_columns(["index"]), path, compression="zstd")
    (old / layout.STATS).unlink()
    info = json.loads((old / layout.INFO).read_text())
    del info["features"]["index"]
    (old / layout.INFO).write_text(json.dumps(info))
    summary = generate(CONFIG, old, RunOptions(workers=1, progress=False))
    assert (summary.made, summary.kept) == (0, 4)
    for rel in (layout.STATS, layout.INFO, layout.data_path(0), layout.data_path(3)):
        assert (old / rel).read_bytes() == (dataset / rel).read_bytes(), rel


def test_cli_export(dataset, tmp_path, capsys):
    from lgmd_sim.cli import main

    pytest.importorskip("av")
    dest = tmp_path / "cli-export"
    assert main(["dataset", "export", str(dataset), str(dest), "--format", "lerobot"]) == 0
    out = capsys.readouterr().out
    assert f"{dest}: 4 episodes" in out and "LeRobotDataset" in out
    assert main(["dataset", "export", str(dataset), str(dest)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lgmd-sim dataset: error: ") and "exists" in err
    assert len(err.splitlines()) == 1
