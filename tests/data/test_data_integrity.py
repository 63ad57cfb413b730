"""A dataset's files are checked as they are read: a data file or video of another episode
is refused, a meta file of the wrong shape is one line naming it, and the card makes the
folder load with Hugging Face `datasets` and documents every column."""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from lgmd_sim import data
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.data import layout
from lgmd_sim.data.generate import GenerateConfig, generate
from lgmd_sim.data.verify import verify

pytest.importorskip("pyarrow")

#: Two episodes of different lengths (the approach ends at the collision).
CONFIG = GenerateConfig(("HandheldApproach",), (0.0,), 2, (16, 24), models=("feedback",),
                        noise=("gaussian:0.005",))


@pytest.fixture(scope="module")
def made(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("integrity") / "ds"
    generate(CONFIG, out, RunOptions(workers=1, progress=False))
    return out


@pytest.fixture
def dataset(made, tmp_path) -> Path:
    """A copy of the dataset that a test may damage."""
    return Path(shutil.copytree(made, tmp_path / "ds"))


def _swap(a: Path, b: Path) -> None:
    tmp = a.with_name("swap")
    a.rename(tmp)
    b.rename(a)
    tmp.rename(b)


def _one_line(exc: pytest.ExceptionInfo, *named: str) -> str:
    text = str(exc.value)
    assert "\n" not in text
    for name in named:
        assert name in text, text
    return text


def test_the_lengths_differ(made):
    ds = data.open(made)
    assert ds[0].length != ds[1].length  # the swaps below change the frame counts too
    assert ds[0].labels.num_rows == ds[0].length and len(ds[0].frames()) == ds[0].length


def test_swapped_data_files_are_refused_naming_the_file(dataset):
    ds = data.open(dataset)
    _swap(ds[0].data_path, ds[1].data_path)
    for read in (lambda: ds[0].labels, lambda: ds.labels(), lambda: ds.labels(["time"]),
                 lambda: next(ds.clips(4, shuffle=False))):
        with pytest.raises(ValueError) as exc:
            read()
        _one_line(exc, str(ds[0].data_path), "episode 1", "episode 0")


def test_data_file_missing_rows_is_refused(dataset):
    import pyarrow.parquet as pq

    ep = data.open(dataset)[0]
    pq.write_table(pq.read_table(ep.data_path).slice(0, 10), ep.data_path)
    with pytest.raises(ValueError) as exc:
        assert ep.labels.num_rows
    _one_line(exc, str(ep.data_path), "10 rows", f"{ep.length} frames")


def test_unreadable_data_file_is_one_line_naming_it(dataset):
    ep = data.open(dataset)[0]
    ep.data_path.write_bytes(b"not parquet")
    with pytest.raises(ValueError) as exc:
        assert ep.labels.num_rows
    _one_line(exc, str(ep.data_path))


def test_swapped_videos_are_refused_naming_the_file(dataset):
    ds = data.open(dataset)
    _swap(ds[0].video_path, ds[1].video_path)
    for read in (lambda: ds[0].frames(), lambda: next(ds[0].iter_frames()),
                 lambda: ds[0].frames(noise="gaussian:0.005"),
                 lambda: data.detect_inputs([f"{dataset}:0"]),
                 lambda: next(ds.clips(4, shuffle=False))):
        with pytest.raises(ValueError) as exc:
            read()
        _one_line(exc, str(ds[0].video_path), "episode 0")
    assert ds[1].labels.num_rows == ds[1].length  # the labels are still served


def test_a_video_is_hashed_once_until_it_changes(dataset, monkeypatch):
    """iter_frames checks the video's SHA-256 once per Episode, not on every pass; a
    file changed since (swapped) is checked again."""
    hashed = []
    sha256 = layout.sha256
    monkeypatch.setattr(layout, "sha256", lambda path: hashed.append(path) or sha256(path))
    ds = data.open(dataset)
    ep = ds[0]
    ep.check_video()
    for _ in range(3):
        assert len(ep.frames()) == ep.length
    assert hashed == [ep.video_path]
    _swap(ds[0].video_path, ds[1].video_path)
    with pytest.raises(ValueError) as exc:
        ep.frames()
    _one_line(exc, str(ep.video_path), "episode 0")


def test_missing_video_is_one_line_naming_it(dataset):
    ep = data.open(dataset)[0]
    ep.video_path.unlink()
    with pytest.raises(ValueError) as exc:
        ep.frames()
    _one_line(exc, str(ep.video_path))


def _bad_info(info: dict) -> list[str]:
    fps_text = {**info, "fps": "30"}
    no_features = {k: v for k, v in info.items() if k != "features"}
    no_camera = {k: v for k, v in info["features"].items() if k != layout.VIDEO_KEY}
    camera = info["features"][layout.VIDEO_KEY]
    cameras = [{**info["features"], layout.VIDEO_KEY: c} for c in (
        [16, 24, 3], {k: v for k, v in camera.items() if k != "shape"},
        {**camera, "shape": [16, 24]}, {**camera, "shape": [16, 0, 3]},
        {**camera, "shape": [16, 24.5, 3]}, {**camera, "shape": [True, 24, 3]})]
    return ["[]", '{"fps": 30}', "{bad", "", json.dumps(fps_text), json.dumps(no_features),
            json.dumps({**info, "total_frames": True}), json.dumps({**info, "fps": 0}),
            json.dumps({**info, "features": no_camera}),
            *(json.dumps({**info, "features": f}) for f in cameras)]


@pytest.mark.parametrize("text", ["[]", "{}", "{bad", '{"video": "webm", "noise": []}',
                                  '{"video": "huffyuv", "noise": "gaussian:0.005"}'])
def test_config_json_of_the_wrong_shape_is_one_line_naming_it(dataset, text):
    (dataset / layout.CONFIG).write_text(text)
    with pytest.raises(ValueError) as exc:
        data.open(dataset)
    _one_line(exc, str(dataset / layout.CONFIG))
    assert verify(dataset)[0] == [str(exc.value)]


def test_config_json_verify_cannot_rebuild_is_one_line_naming_it(dataset):
    config = json.loads((dataset / layout.CONFIG).read_text())
    del config["scenarios"]
    (dataset / layout.CONFIG).write_text(json.dumps(config))
    data.open(dataset)  # the loader does not need the scenarios
    (problem,) = verify(dataset)[0]
    assert str(dataset / layout.CONFIG) in problem and "scenarios" in problem
    config["scenarios"] = ["NoSuchScenario"]
    (dataset / layout.CONFIG).write_text(json.dumps(config))
    (problem,) = verify(dataset)[0]
    assert str(dataset / layout.CONFIG) in problem and "NoSuchScenario" in problem


def _damage_table(path: Path, how: str) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    if how == "garbage":
        path.write_bytes(b"PAR1 not parquet")
        return
    table = pq.read_table(path)
    if how == "no scenario":
        table = table.drop(["scenario"])
    elif how == "no episode_index":
        table = table.drop(["episode_index"])
    elif how == "length as text":
        table = table.set_column(table.schema.get_field_index("length"), "length",
                                 pa.array([str(n) for n in table["length"].to_pylist()]))
    pq.write_table(table, path)


@pytest.mark.parametrize("how", ["garbage", "no scenario", "no episode_index",
                                 "length as text"])
def test_episode_table_of_the_wrong_shape_is_one_line_naming_it(dataset, how):
    _damage_table(dataset / layout.EPISODES, how)
    with pytest.raises(ValueError) as exc:
        data.open(dataset)
    _one_line(exc, str(dataset / layout.EPISODES))
    assert verify(dataset)[0] == [str(exc.value)]


@pytest.mark.parametrize("how", ["garbage", "no scenario", "renumbered"])
def test_verify_reads_the_task_table(dataset, how):
    import pyarrow as pa
    import pyarrow.parquet as pq

    tasks = dataset / layout.TASKS
    if how == "garbage":
        tasks.write_bytes(b"not parquet")
    elif how == "no scenario":
        pq.write_table(pq.read_table(tasks).drop(["scenario"]), tasks)
    else:
        table = pq.read_table(tasks)
        pq.write_table(table.set_column(0, "task_index", pa.array([5], pa.int64())), tasks)
    problems = verify(dataset)[0]
    assert len(problems) == 1 and str(tasks) in problems[0]


def test_card_documents_every_column_from_the_one_declaration(made):
    info = json.loads((made / layout.INFO).read_text())
    card = (made / layout.CARD).read_text()
    columns = [c.name for c in layout.columns(CONFIG.models, CONFIG.noise)]
    assert set(info["features"]) - {layout.VIDEO_KEY} == set(columns)
    assert columns == data.open(made)[0].labels.column_names
    assert "index" in columns and "feedback.alarm[gaussian:0.005]" in columns
    rows = {line.split(" | ")[0].strip("|` "): line for line in card.splitlines()
            if line.startswith("| `")}
    assert list(rows) == columns
    for name in columns:
        feature = info["features"][name]
        assert f"| {feature['dtype']}" in rows[name], name
        assert f"| {feature['unit'] or '-'} | {feature['doc']} |" in rows[name], name
    assert "| m/s |" in rows["camera_linvel"] and "| s |" in rows["threat_ttc"]
    assert "meta/stats.json" in card


def test_card_front_matter_names_the_label_files(made):
    yaml = pytest.importorskip("yaml")
    card = (made / layout.CARD).read_text()
    assert card.startswith("---\n")
    front = yaml.safe_load(card.split("---\n")[1])
    (config,) = front["configs"]
    assert config["config_name"].startswith("labels-") and config["default"] is True
    assert config["data_files"] == [{"split": "train",
                                    "path": "data/chunk-*/file-*.parquet"}]


def test_hugging_face_datasets_loads_the_folder_as_the_label_table(made, tmp_path):
    if importlib.util.find_spec("datasets") is None:
        pytest.skip("datasets is not installed here")
    code = ("import sys, datasets; t = datasets.load_dataset(sys.argv[1])['train']; "
            "print(t.num_rows, ','.join(t.column_names))")
    env = {**os.environ, "HF_DATASETS_CACHE": str(tmp_path / "cache"), "HF_HUB_OFFLINE": "1"}
    result = subprocess.run([sys.executable, "-c", code, str(made)], capture_output=True,
                            text=True, cwd=tmp_path, env=env, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    rows, names = result.stdout.split()[-2:]
    ds = data.open(made)
    assert int(rows) == ds.info["total_frames"]
    assert names.split(",") == ds[0].labels.column_names


def test_two_datasets_in_folders_of_one_name_load_their_own_rows_through_one_cache(
        made, tmp_path):
    """`datasets` keys its cache of ``load_dataset("DIR")`` on the folder's name and the
    card's ``configs`` block: the second ``ds`` must not be served the first one's rows."""
    if importlib.util.find_spec("datasets") is None:
        pytest.skip("datasets is not installed here")
    other = tmp_path / "other" / made.name
    generate(replace(CONFIG, episodes=1, seed=7, overrides={"time_limit": 0.3}), other,
             RunOptions(workers=1, progress=False))
    columns = ["episode_index", "frame_index", "time", "threat_distance"]
    code = ("import json, sys, datasets; print(json.dumps([datasets.load_dataset(d, "
            "cache_dir=sys.argv[1])['train'].select_columns(sys.argv[2].split(',')).to_dict() "
            "for d in sys.argv[3:]]))")
    env = {**os.environ, "HF_DATASETS_OFFLINE": "1", "HF_HUB_OFFLINE": "1"}
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path / "cache"),
                             ",".join(columns), str(made), str(other)],
                            capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    loaded = json.loads(result.stdout.splitlines()[-1])
    own = [data.open(d).labels(columns).to_pydict() for d in (made, other)]
    assert own[0] != own[1]
    assert [len(t["time"]) for t in loaded] == [len(t["time"]) for t in own]
    assert loaded == own


@pytest.mark.parametrize("case", range(15))
def test_info_json_of_the_wrong_shape_is_one_line_naming_it(dataset, case, capsys):
    from lgmd_sim.cli import main

    info = json.loads((dataset / layout.INFO).read_text())
    (dataset / layout.INFO).write_text(_bad_info(info)[case])
    with pytest.raises(ValueError) as exc:
        data.open(dataset)
    _one_line(exc, str(dataset / layout.INFO))
    problems, _counts = verify(dataset)
    assert problems == [str(exc.value)]
    assert main(["dataset", "verify", str(dataset)]) == 1
    assert capsys.readouterr().err.count("\n") == 1
