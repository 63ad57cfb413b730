"""The detect library: a truncated or one-frame video, every model through it, the video
reader, the alarm rule in a summary and figure (the command: tests/cli/test_detect_command.py)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.detect import detect, detect_video
from lgmd_sim.signals import metrics, stimuli
from lgmd_sim.signals.video import VideoReader, natural_key

from footage import MODELS, SHAPE, looming_clip, write_folder, write_video


@pytest.fixture(scope="module")
def clip() -> stimuli.Stimulus:
    return looming_clip()


def test_truncated_video_names_the_frame(tmp_path, clip):
    video = write_video(tmp_path / "cut.avi", clip.frames, fourcc="MJPG")
    data = video.read_bytes()
    video.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cut\.avi.*decoding failed at frame \d+"):
        detect_video(video, [MODELS[0]])


def test_single_frame_is_an_error(tmp_path, clip):
    folder = write_folder(tmp_path / "one", clip.frames[:1])
    with pytest.raises(ValueError, match="at least 2 frames"):
        detect_video(folder, [MODELS[0]])


@pytest.mark.parametrize("name", models.available())
def test_every_model_runs_through_detect(name, clip):
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
    folder = write_folder(tmp_path / "imgs", clip.frames[:3])
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
    video = VideoReader(write_video(tmp_path / "v.mp4", clip.frames, fps=25.0))
    assert (video.fps, video.frame_count) == (25.0, len(clip))
    first = next(iter(video))
    assert first.shape == (*SHAPE, 3) and abs(first.mean() - clip.frames[0].mean()) < 8
    red = np.zeros((4, 4, 3), np.uint8)
    red[..., 2] = 255  # OpenCV writes BGR
    colour = tmp_path / "colour"
    colour.mkdir()
    cv2.imwrite(str(colour / "a.png"), red)
    assert next(iter(VideoReader(colour)))[0, 0].tolist() == [255, 0, 0]  # read as RGB


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
