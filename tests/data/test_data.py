"""lgmd_sim.data: generate, verify and load a tiny dataset; the same bytes from 1 worker,
2 workers and Ray; labels readable without lgmd-sim; detect and PyTorch on a dataset."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import data
from lgmd_sim.core.parallel import RunOptions
from lgmd_sim.data import layout
from lgmd_sim.data.generate import GenerateConfig, generate
from lgmd_sim.data.verify import verify
from lgmd_sim.signals import noise

from datasets_tiny import CONFIG, tree

pytest.importorskip("pyarrow")

@pytest.mark.slow
def test_generated_dataset_verifies_and_holds_both_outcomes(tiny_dataset):
    problems, counts = verify(tiny_dataset)
    assert problems == []
    ds = data.open(tiny_dataset)
    assert counts["episodes"] == len(ds) == 8
    assert counts["frames"] == ds.info["total_frames"] == ds.labels().num_rows
    assert {ep.outcome for ep in ds.filter(scenario="HandheldApproach")} == {"collision"}
    assert {ep.outcome for ep in ds.filter(scenario="PassBy")} == {"near_miss"}
    for ep in ds.filter(outcome="collision"):
        flags = ep.labels["collision"].to_numpy(zero_copy_only=False)
        assert ep.collision_frame == int(np.flatnonzero(flags)[0]) == ep.length - 1
    assert len(ds.filter(scenario="PassBy", jitter=1)) == 2
    assert len(ds.filter(outcome=["clear"])) == 0
    info = json.loads((tiny_dataset / layout.INFO).read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 30.0
    assert info["features"][layout.VIDEO_KEY]["info"]["video.codec"] == "huffyuv"
    card = (tiny_dataset / layout.CARD).read_text()
    assert CONFIG.command() in card and "| HandheldApproach | 1 | 2 |" in card


def test_frames_are_exact_and_noise_views_reproduce_their_labels(tiny_dataset):
    import gymnasium as gym

    from lgmd_sim import models
    from lgmd_sim.controllers import make, rollout
    from lgmd_sim.core.frames import to_grey

    ep = data.open(tiny_dataset).filter(scenario="HandheldApproach", jitter=1)[1]
    frames = ep.frames()
    assert frames.shape == (ep.length, 32, 48, 3) and frames.dtype == np.uint8
    env = gym.make("lgmd_sim/HandheldApproach-v0", jitter=1.0, resolution=[32, 48])
    rendered = [s.obs["frame"] for s in rollout(env, make("straight"), seed=ep.seed)]
    env.close()
    assert np.array_equal(np.stack(rendered), frames)  # lossless: exact pixels
    noisy = ep.frames(noise="saltpepper:0.01")
    spec = noise.parse("saltpepper:0.01")
    assert np.array_equal(noisy[5], noise.apply(frames[5], spec, ep.seed, 5))
    model = models.make("feedback")
    potentials = [model.step(to_grey(f)).potential for f in noisy]
    labelled = ep.labels["feedback.potential[saltpepper:0.01]"].to_numpy()
    np.testing.assert_array_equal(potentials, labelled)


def test_clip_sampler_gives_every_window_once(tiny_dataset):
    ds = data.open(tiny_dataset).filter(jitter=0)
    clips = list(ds.clips(8, stride=4, seed=1))
    assert len(clips) == len(ds.windows(8, 4))
    assert len({(c.episode.index, c.start) for c in clips}) == len(clips)
    for c in clips[:5]:
        assert c.frames.shape == (8, 32, 48, 3)
        assert c.labels["frame_index"].to_pylist() == list(range(c.start, c.start + 8))


@pytest.mark.slow
def test_same_bytes_from_two_workers(tiny_dataset, tmp_path):
    generate(CONFIG, tmp_path / "two", RunOptions(workers=2, progress=False))
    assert tree(tmp_path / "two") == tree(tiny_dataset)


@pytest.mark.slow
def test_same_bytes_on_ray(tiny_dataset, tmp_path):
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False,
             configure_logging=False)
    try:
        generate(CONFIG, tmp_path / "ray", RunOptions(ray_address="auto", progress=False))
    finally:
        ray.shutdown()
    assert tree(tmp_path / "ray") == tree(tiny_dataset)


LOADERS = {
    "pyarrow": "import pyarrow.parquet as pq; t = pq.read_table(D + '/data'); n = t.num_rows",
    "pandas": "import pandas as pd; n = len(pd.read_parquet(D + '/data'))",
    "datasets": "from datasets import load_dataset; "
                "n = len(load_dataset('parquet', data_files=D + '/data/*/*.parquet')['train'])",
}


@pytest.mark.parametrize("tool", list(LOADERS))
def test_labels_load_without_lgmd_sim(tiny_dataset, tool, tmp_path):
    if importlib.util.find_spec(tool) is None:
        pytest.skip(f"{tool} is not installed here")
    code = (f"import sys; D = {str(tiny_dataset)!r}; {LOADERS[tool]}; "
            "assert not any(m.startswith('lgmd_sim') for m in sys.modules); print(n)")
    env = {**os.environ, "HF_DATASETS_CACHE": str(tmp_path), "HF_HUB_OFFLINE": "1"}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=tmp_path, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert int(result.stdout.split()[-1]) == data.open(tiny_dataset).info["total_frames"]


def test_torch_window_dataset(tiny_dataset):
    torch = pytest.importorskip("torch")
    from lgmd_sim.data.torch import WindowDataset

    windows = WindowDataset(data.open(tiny_dataset), 6, columns=["threat_ttc", "collision"])
    frames, labels = windows[len(windows) - 1]
    assert frames.shape == (6, 32, 48, 3) and frames.dtype == torch.uint8
    assert labels.shape == (6, 2) and labels[-1, 1] == 1  # ends at the collision
    batch = next(iter(torch.utils.data.DataLoader(windows, batch_size=4)))
    assert batch[0].shape == (4, 6, 32, 48, 3)


@pytest.mark.parametrize("video", ["ffv1", "mpeg4"])
def test_other_video_formats_record_their_codec(tmp_path, video):
    config = GenerateConfig(("StationaryApproach",), (0.0,), 1, (32, 48), video=video,
                            overrides={"time_limit": 0.5})
    generate(config, tmp_path / video, RunOptions(workers=1, progress=False))
    assert verify(tmp_path / video)[0] == []
    ds = data.open(tmp_path / video)
    fmt = layout.VIDEO_FORMATS[video]
    assert ds.info["features"][layout.VIDEO_KEY]["info"]["video.codec"] == fmt.codec
    assert ds[0].video_path.suffix == fmt.suffix
    assert ds[0].frames().shape == (16, 32, 48, 3)
    generate(config, tmp_path / "again", RunOptions(workers=1, progress=False))
    assert tree(tmp_path / "again") == tree(tmp_path / video)  # the same bytes again


def test_docs_describe_every_label_column():
    text = (Path(__file__).resolve().parents[2] / "docs" / "guides" / "datasets.md").read_text()
    assert [c.name for c in layout.COLUMNS if f"| `{c.name}` |" not in text] == []
