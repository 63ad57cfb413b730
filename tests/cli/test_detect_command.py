"""`lgmd-sim detect` end to end: videos and image folders in, CSV, JSON and a figure out;
bad input one line naming it; noise, presets and front ends by option."""

from __future__ import annotations

import csv
import json
import os

import numpy as np
import pytest

from lgmd_sim import cli, data, models
from lgmd_sim.controllers.options import model_names
from lgmd_sim.detect import detect
from lgmd_sim.signals import stimuli
from lgmd_sim.signals.video import VideoReader

from footage import MODELS, looming_clip, turning_scene, write_folder, write_video


@pytest.fixture(scope="module")
def clip() -> stimuli.Stimulus:
    return looming_clip()


def _detect(*args: str) -> int:
    return cli.main(["detect", *args, "--no-progress"])


def test_video_writes_csv_json_and_figure(tmp_path, clip, capsys):
    video = write_video(tmp_path / "approach.mp4", clip.frames)
    out = tmp_path / "out"
    assert _detect(str(video), "--models", ",".join(MODELS), "--out", str(out),
                   "--collision-frame", str(clip.collision_frame)) == 0
    assert sorted(p.name for p in out.iterdir()) == ["approach.csv", "approach.json",
                                                     "approach.png"]
    stdout = capsys.readouterr().out
    assert "approach.mp4" in stdout and str(out / "approach.png") in stdout

    with (out / "approach.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(clip)
    assert list(rows[0]) == ["frame", "time_s", "ssim"] + [
        c for n in MODELS for c in (f"{n}_potential", f"{n}_alarm")
    ]
    assert rows[0]["ssim"] == "" and 0 < float(rows[1]["ssim"]) <= 1
    assert float(rows[15]["time_s"]) == pytest.approx(0.5)

    summary = json.loads((out / "approach.json").read_text())
    assert summary["video"] == str(video) and summary["frames"] == len(clip)
    assert summary["fps"] == pytest.approx(30.0) and 0 < summary["isi"] < 1
    assert list(summary["models"]) == MODELS
    for name in MODELS:
        m = summary["models"][name]
        assert {"first_alarm", "si", "si_crossed", "mpsi", "outcome", "lead_frames",
                "lead_s", "window_frames"} <= set(m)
        alarms = [int(r[f"{name}_alarm"]) for r in rows]
        assert m["first_alarm"] == (alarms.index(1) if 1 in alarms else None)
        assert m["si_crossed"] == (m["first_alarm"] is not None)
    assert (out / "approach.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_image_folder_in_natural_order_with_json_stdout(tmp_path, clip, capsys):
    folder = write_folder(tmp_path / "shots", clip.frames)
    video = write_video(tmp_path / "other.mp4", clip.frames)
    out = tmp_path / "out"
    assert _detect(str(folder), str(video), "--json", "--models", MODELS[0],
                   "--out", str(out)) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2  # one JSON object per video, nothing else
    records = [json.loads(line) for line in lines]
    assert [r["video"] for r in records] == [str(folder), str(video)]
    for r in records:
        assert {"video", "frames", "fps", "isi", "models"} <= set(r)
        m = r["models"][MODELS[0]]
        assert {"first_alarm", "si", "mpsi", "membrane_potential"} <= set(m)
        assert len(m["membrane_potential"]) == r["frames"] == len(clip)
    # PNG is lossless: the folder gives exactly the in-memory result, so the order was 0,1,..,10
    direct = detect(clip.frames, 30.0, [MODELS[0]])
    np.testing.assert_allclose(records[0]["models"][MODELS[0]]["membrane_potential"],
                               direct.models[MODELS[0]].potential, atol=1e-6)
    assert records[0]["fps"] == 30.0
    assert sorted(p.name for p in out.iterdir()) == [
        "other.csv", "other.json", "other.png", "shots.csv", "shots.json", "shots.png"]


@pytest.mark.parametrize("make_bad", [
    lambda d: (d / "noise.mp4").write_bytes(os.urandom(5000)) and d / "noise.mp4",
    lambda d: (d / "empty").mkdir() or d / "empty",
    lambda d: d / "missing.avi",
    lambda d: (d / "notes.txt").write_text("not a video") and d / "notes.txt",
])
def test_bad_input_exits_2_naming_it_and_leaves_nothing(tmp_path, make_bad, capfd):
    bad = make_bad(tmp_path)
    out = tmp_path / "out"
    assert _detect(str(bad), "--models", MODELS[0], "--out", str(out)) == 2
    captured = capfd.readouterr()  # file-descriptor level: FFmpeg's own logging counts too
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and str(bad) in err[0] and err[0].startswith("lgmd-sim detect: error:")
    assert captured.out == ""
    assert not out.exists() or not any(out.iterdir())


def test_a_bad_video_does_not_stop_the_good_ones(tmp_path, clip, capsys):
    good = write_video(tmp_path / "good.mp4", clip.frames)
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(os.urandom(3000))
    out = tmp_path / "out"
    assert _detect(str(bad), str(good), "--json", "--models", MODELS[0], "--out", str(out)) == 2
    captured = capsys.readouterr()
    assert "bad.mp4" in captured.err
    assert [json.loads(x)["video"] for x in captured.out.splitlines()] == [str(good)]
    assert sorted(p.name for p in out.iterdir()) == ["good.csv", "good.json", "good.png"]


def test_unknown_model_and_bad_collision_frame(tmp_path, clip, capsys):
    video = write_video(tmp_path / "a.mp4", clip.frames)
    assert _detect(str(video), "--models", f"{MODELS[0]},lgmd9", "--out", str(tmp_path)) == 2
    err = capsys.readouterr().err
    assert "lgmd9" in err and all(n in err for n in models.available())
    assert _detect(str(video), "--models", MODELS[0], "--collision-frame", "999",
                   "--out", str(tmp_path / "o")) == 2
    assert "999" in capsys.readouterr().err and not (tmp_path / "o").exists()
    with pytest.raises(ValueError, match="valid: all"):
        model_names(",")
    assert model_names("all") == models.available()
    assert model_names(f"{MODELS[0]}, {MODELS[0]}") == [MODELS[0]]


def test_json_without_out_prints_and_writes_no_files(tmp_path, clip, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    video = write_video(tmp_path / "a.mp4", clip.frames)
    assert _detect(str(video), "--models", MODELS[0], "--json") == 0
    record = json.loads(capsys.readouterr().out)
    assert record["outputs"] == {} and record["frames"] == len(clip.frames)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]  # no ./detect-out
    assert _detect(str(video), "--models", MODELS[0]) == 0  # without --json: ./detect-out
    assert (tmp_path / "detect-out" / "a.json").exists()


def test_noise_corrupts_the_frames_before_models_and_ssim_and_is_recorded(tmp_path, clip,
                                                                          capsys):
    from lgmd_sim.signals import noise

    folder = write_folder(tmp_path / "shots", clip.frames)  # PNG: lossless
    spec = "gaussian:0.005,saltpepper:0.005"
    assert _detect(str(folder), "--json", "--models", MODELS[0], "--noise", spec,
                   "--noise-seed", "3") == 0
    noisy = json.loads(capsys.readouterr().out)
    assert (noisy["noise"], noisy["noise_seed"]) == (spec, 3)
    expected = detect(noise.corrupt(VideoReader(folder), noise.parse(spec), 3), 30.0,
                      [MODELS[0]])
    np.testing.assert_allclose(noisy["models"][MODELS[0]]["membrane_potential"],
                               expected.models[MODELS[0]].potential, atol=1e-6)
    assert noisy["isi"] == pytest.approx(expected.isi)
    assert _detect(str(folder), "--json", "--models", MODELS[0]) == 0
    clean = json.loads(capsys.readouterr().out)
    assert (clean["noise"], clean["noise_seed"]) == (None, None)
    assert noisy["isi"] < clean["isi"] - 0.05  # the SSIM saw the noise too
    assert (noisy["models"][MODELS[0]]["membrane_potential"]
            != clean["models"][MODELS[0]]["membrane_potential"])


def test_a_bad_noise_spec_is_one_line_before_any_video_is_read(tmp_path, capfd):
    missing = tmp_path / "missing.mp4"  # would be an error of its own if it were read
    assert _detect(str(missing), "--noise", "gauss:0.1", "--out", str(tmp_path / "o")) == 2
    captured = capfd.readouterr()
    err = captured.err.strip().splitlines()
    assert err == ["lgmd-sim detect: error: unknown noise 'gauss'; known: gaussian, "
                   "saltpepper, shake, exposure, sensor, blur, jpeg"]
    assert captured.out == "" and not (tmp_path / "o").exists()


def test_preset_applies_to_every_model_that_has_it(tmp_path, clip, capsys):
    video = write_video(tmp_path / "a.mp4", clip.frames)
    assert _detect(str(video), "--models", "feedback,lgmd1", "--preset", "paper-text",
                   "--json") == 0
    record = json.loads(capsys.readouterr().out)
    assert list(record["models"]) == ["feedback/paper-text", "lgmd1"]
    assert _detect(str(video), "--models", "lgmd1", "--preset", "nope", "--json") == 2
    assert "has a preset 'nope'" in capsys.readouterr().err


def test_models_take_model_slash_preset_as_everywhere(tmp_path, clip, capsys):
    """docs/concepts.md's one spelling: `--models lgmd1/robot-image` runs lgmd1 at that
    preset (it was refused: "a preset goes in --preset"); --preset goes to the models
    listed without one, and naming it again for the same model is no conflict."""
    video = write_video(tmp_path / "a.mp4", clip.frames)
    assert _detect(str(video), "--models", "lgmd1/robot-image,feedback", "--preset",
                   "robot-image", "--json") == 0
    record = json.loads(capsys.readouterr().out)
    assert list(record["models"]) == ["lgmd1/robot-image", "feedback/robot-image"]
    assert record["models"]["lgmd1/robot-image"]["stabilize"] == "image"
    assert list(detect(clip.frames, 30.0, "lgmd1/robot-image").models) == ["lgmd1/robot-image"]


@pytest.mark.parametrize(("args", "message"), [
    (["--models", "lgmd1/robot", "--preset", "video"],
     "detector 'lgmd1/robot' names preset 'robot', --preset 'video': give a model's preset "
     "once, in --models or in --preset"),
    (["--models", "lgmd1+imu"], "detector 'lgmd1+imu': a video has no pose or IMU, so its "
                                "front ends are +image, +gain, not +imu"),
    (["--models", "lgmd1/nope"], "unknown preset 'nope' for model 'lgmd1'"),
])
def test_models_with_a_preset_refuse_a_conflict_in_one_line(tmp_path, clip, capsys, args,
                                                            message):
    video = write_video(tmp_path / "a.mp4", clip.frames)
    out = tmp_path / "out"
    assert _detect(str(video), *args, "--out", str(out)) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"lgmd-sim detect: error: {message}") and len(err.splitlines()) == 1
    assert not out.exists()


@pytest.mark.slow
def test_preset_video_alone_runs_every_model_with_the_front_end_footage_needs(
        tmp_path, clip, capsys):
    """`lgmd-sim detect VIDEO --preset video` with no other option: every model at its
    shipped video preset, the rotation and the gain fitted from the frames."""
    video = write_video(tmp_path / "a.mp4", clip.frames)
    assert _detect(str(video), "--preset", "video", "--json") == 0
    record = json.loads(capsys.readouterr().out)
    assert list(record["models"]) == [f"{name}/video" for name in models.available()]
    for name in models.available():
        params = models.make(name, preset="video").params
        assert (params.stabilize, params.gain) == ("image", True)
        got = record["models"][f"{name}/video"]
        assert (got["alarm_frames"], got["alarm_rising"]) == (4, True)


def test_an_alarm_on_the_collision_frame_is_a_hit_with_lead_0_as_the_benchmarks_count_it(
        tmp_path, clip, capsys):
    """The rule `--help` states: a first alarm in the window before the collision frame,
    that frame included, is a hit; `--window` sets the window as `bench open-loop` does."""
    from lgmd_sim.detect.figure import alarm_label
    from lgmd_sim.signals.metrics import evaluate_clip

    video = write_video(tmp_path / "a.mp4", clip.frames)

    def summary(*extra: str) -> dict:
        assert _detect(str(video), "--models", MODELS[0], "--json", *extra) == 0
        return json.loads(capsys.readouterr().out)["models"][MODELS[0]]

    first = summary()["first_alarm"]
    assert first is not None and first > 0
    on = summary("--collision-frame", str(first))
    assert (on["outcome"], on["lead_frames"], on["lead_s"]) == ("hit", 0, 0.0)
    ev = evaluate_clip([0.0] * first + [1.0], first, 30.0)
    assert alarm_label("m", first, ev) == (
        f"m: alarm at {first}, hit (at the collision frame), lead 0.00 s")
    after = summary("--collision-frame", str(first + 1), "--window", "0")
    assert (after["outcome"], after["lead_frames"]) == ("miss", 1)
    assert summary("--collision-frame", str(first + 1))["outcome"] == "hit"


def test_detect_stabilize_image_equals_the_compensated_models(tmp_path, capfd):
    frames, _ = turning_scene(6, (72, 96), seed=7)
    folder = write_folder(tmp_path / "shots", frames)
    assert _detect(str(folder), "--json", "--models", "lgmd1,lgmd2", "--stabilize",
                   "gain+image", "--fov", "55") == 0
    record = json.loads(capfd.readouterr().out)
    expected = detect(VideoReader(folder), 30.0, {
        "lgmd1": models.make("lgmd1", preset="published+image+gain"),
        "lgmd2": models.make("lgmd2", preset="published+image+gain")})
    for name in ("lgmd1", "lgmd2"):
        got = record["models"][name]
        assert (got["stabilize"], got["fovy"]) == ("image+gain", 55.0)
        np.testing.assert_allclose(got["membrane_potential"],
                                   expected.models[name].potential, atol=1e-6)
    assert _detect(str(folder), "--stabilize", "pose", "--out", str(tmp_path / "o")) == 2
    assert "a video has no pose or IMU" in capfd.readouterr().err


@pytest.mark.slow
def test_detect_runs_on_a_dataset_and_on_one_episode(tiny_dataset, tmp_path, capsys):
    from lgmd_sim.cli import main

    ds = data.open(tiny_dataset)
    hit = ds.filter(outcome="collision")[0]
    assert main(["detect", f"{tiny_dataset}:{hit.index}", "--models", "lgmd2", "--json",
                 "--no-progress"]) == 0
    (record,) = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert record["collision_frame"] == hit.collision_frame
    assert record["frames"] == hit.length
    assert record["isi"] == pytest.approx(hit.meta["isi"])
    assert main(["detect", str(tiny_dataset), "--models", "lgmd2", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    assert len(list(tmp_path.glob("episode_*.json"))) == len(ds)
    assert main(["detect", f"{tiny_dataset}:99", "--models", "lgmd2", "--json"]) == 2
    assert "no episode 99" in capsys.readouterr().err
