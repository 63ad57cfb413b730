"""`lgmd-sim detect` end to end, the video reader, and the detect library functions."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from lgmd_sim import cli, models
from lgmd_sim.controllers.options import model_names
from lgmd_sim.detect import detect, detect_video
from lgmd_sim.signals import metrics, stimuli
from lgmd_sim.signals.video import VideoReader, natural_key

SHAPE = (60, 80)


def _importable(name: str) -> bool:
    try:
        models.model_class(name)
    except ImportError:
        return False
    return True


# the models written so far; every test below covers all five once they exist
MODELS = [n for n in models.available() if _importable(n)]
pytestmark = pytest.mark.skipif(not MODELS, reason="no LGMD model module yet")


@pytest.fixture(scope="module")
def clip() -> stimuli.Stimulus:
    return stimuli.approaching(SHAPE, start_distance=1.0, speed=2.0, still_frames=3,
                               look=stimuli.Look(background="texture"))


def _write_video(path: Path, frames: np.ndarray, fourcc: str = "mp4v", fps: float = 30.0):
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, SHAPE[::-1])
    assert w.isOpened()
    for f in frames:
        w.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
    w.release()
    return path


def _write_folder(folder: Path, frames: np.ndarray) -> Path:
    folder.mkdir()
    for i, f in enumerate(frames):  # unpadded numbers: natural order, not name order
        cv2.imwrite(str(folder / f"frame{i}.png"), f)
    return folder


def _detect(*args: str) -> int:
    return cli.main(["detect", *args, "--no-progress"])


def test_video_writes_csv_json_and_figure(tmp_path, clip, capsys):
    video = _write_video(tmp_path / "approach.mp4", clip.frames)
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
    folder = _write_folder(tmp_path / "shots", clip.frames)
    video = _write_video(tmp_path / "other.mp4", clip.frames)
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
    good = _write_video(tmp_path / "good.mp4", clip.frames)
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(os.urandom(3000))
    out = tmp_path / "out"
    assert _detect(str(bad), str(good), "--json", "--models", MODELS[0], "--out", str(out)) == 2
    captured = capsys.readouterr()
    assert "bad.mp4" in captured.err
    assert [json.loads(x)["video"] for x in captured.out.splitlines()] == [str(good)]
    assert sorted(p.name for p in out.iterdir()) == ["good.csv", "good.json", "good.png"]


def test_truncated_video_names_the_frame(tmp_path, clip):
    video = _write_video(tmp_path / "cut.avi", clip.frames, fourcc="MJPG")
    data = video.read_bytes()
    video.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cut\.avi.*decoding failed at frame \d+"):
        detect_video(video, [MODELS[0]])


def test_unknown_model_and_bad_collision_frame(tmp_path, clip, capsys):
    video = _write_video(tmp_path / "a.mp4", clip.frames)
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


def test_single_frame_is_an_error(tmp_path, clip):
    folder = _write_folder(tmp_path / "one", clip.frames[:1])
    with pytest.raises(ValueError, match="at least 2 frames"):
        detect_video(folder, [MODELS[0]])


@pytest.mark.parametrize("name", models.available())
def test_every_model_runs_through_detect(name, clip):
    if not _importable(name):
        pytest.skip(f"model {name!r} not written yet")
    d = detect(clip.frames, clip.fps, [name], clip.collision_frame, name="approach")
    tr = d.models[name]
    assert tr.potential.shape == tr.alarm.shape == (len(clip),)
    assert np.all((tr.potential >= 0.5) & (tr.potential < 1))
    np.testing.assert_array_equal(tr.alarm, tr.potential > tr.threshold)
    assert tr.event is not None and tr.event.collision_frame == clip.collision_frame
    assert tr.mpsi == pytest.approx(tr.potential.max() / tr.potential.mean())
    # a model instance may be passed in (another preset, other parameters)
    again = detect(clip.frames, clip.fps, {name: models.make(name)})
    np.testing.assert_array_equal(again.models[name].potential, tr.potential)


def test_video_reader(tmp_path, clip):
    assert sorted(["f10.png", "f2.png", "F1.png"], key=natural_key) == [
        "F1.png", "f2.png", "f10.png"]
    folder = _write_folder(tmp_path / "imgs", clip.frames[:3])
    (folder / "readme.txt").write_text("skipped")
    reader = VideoReader(folder)
    assert (reader.fps, reader.frame_count, reader.is_folder) == (30.0, 3, True)
    frames = list(reader)
    assert len(frames) == 3 and frames[0].shape == (*SHAPE, 3) and frames[0].dtype == np.uint8
    assert list(reader)[2].tobytes() == frames[2].tobytes()  # iterable again
    cv2.imwrite(str(folder / "frame3.png"), np.zeros((10, 10), np.uint8))
    with pytest.raises(ValueError, match=r"frame3\.png.*10x10"):
        list(VideoReader(folder))
    (folder / "frame3.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match=r"cannot read image .*frame3\.png"):
        list(VideoReader(folder))
    video = VideoReader(_write_video(tmp_path / "v.mp4", clip.frames, fps=25.0))
    assert (video.fps, video.frame_count) == (25.0, len(clip))
    first = next(iter(video))
    assert first.shape == (*SHAPE, 3) and abs(first.mean() - clip.frames[0].mean()) < 8
    red = np.zeros((4, 4, 3), np.uint8)
    red[..., 2] = 255  # OpenCV writes BGR
    colour = tmp_path / "colour"
    colour.mkdir()
    cv2.imwrite(str(colour / "a.png"), red)
    assert next(iter(VideoReader(colour)))[0, 0].tolist() == [255, 0, 0]  # read as RGB


def test_json_without_out_prints_and_writes_no_files(tmp_path, clip, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    video = _write_video(tmp_path / "a.mp4", clip.frames)
    assert _detect(str(video), "--models", MODELS[0], "--json") == 0
    record = json.loads(capsys.readouterr().out)
    assert record["outputs"] == {} and record["frames"] == len(clip.frames)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]  # no ./detect-out
    assert _detect(str(video), "--models", MODELS[0]) == 0  # without --json: ./detect-out
    assert (tmp_path / "detect-out" / "a.json").exists()


def test_noise_corrupts_the_frames_before_models_and_ssim_and_is_recorded(tmp_path, clip,
                                                                          capsys):
    from lgmd_sim.signals import noise

    folder = _write_folder(tmp_path / "shots", clip.frames)  # PNG: lossless
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
    video = _write_video(tmp_path / "a.mp4", clip.frames)
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
    video = _write_video(tmp_path / "a.mp4", clip.frames)
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
    video = _write_video(tmp_path / "a.mp4", clip.frames)
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
    video = _write_video(tmp_path / "a.mp4", clip.frames)
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

    video = _write_video(tmp_path / "a.mp4", clip.frames)

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


def test_a_models_alarm_rule_is_in_its_summary_and_the_figures_legend(clip):
    """A model whose alarm needs several rising frames: the detection's first alarm and
    SI follow the rule, the JSON names it, the figure says it beside the thresholds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from lgmd_sim.detect import detect
    from lgmd_sim.detect.figure import draw_potentials

    built = {"plain": models.make("lgmd1"),
             "held": models.make("lgmd1", alarm_frames=4, alarm_rising=True)}
    d = detect(clip.frames, clip.fps, built)
    rule = metrics.AlarmRule(4, rising=True)
    held = d.models["held"]
    assert held.first_alarm == metrics.first_alarm(held.potential, held.threshold, rule)
    assert held.first_alarm != d.models["plain"].first_alarm
    assert (held.summary()["alarm_frames"], held.summary()["alarm_rising"]) == (4, True)
    fig, ax = plt.subplots()
    draw_potentials(ax, d)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "held: an alarm is 4 rising frames running above the threshold" in labels
    plt.close(fig)
