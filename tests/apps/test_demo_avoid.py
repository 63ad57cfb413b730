"""`lgmd-sim demo`'s closed-loop episode: the robot avoiding obstacles with ReactiveAvoid,
its alarms the controller's, drawn where they happened, the video and figure written
with the demo's other files (all of them or none), and a bad avoider refused up front."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lgmd_sim.apps import avoid as demo_avoid
from lgmd_sim.apps import demo

#: At 64 x 64 this detector alarms (it is calibrated at 120 x 160) and the episode is short.
SMALL = {"seed": 3, "jitter": 1.0, "detector": "lgmd1/calibrated-image", "resolution": "small"}


@pytest.fixture(scope="module")
def episode():
    return demo_avoid.drive(**SMALL)


def test_the_onsets_are_where_the_controllers_alarm_turns_on(episode):
    n = len(episode.frames)
    assert episode.path.shape == (n, 2) and episode.potential.shape == (n,)
    assert np.isnan(episode.potential[-1]) and not episode.alarm[-1]  # it does not act
    # the controller alarms where its model's potential is above the threshold
    above = episode.potential[:-1] > episode.threshold
    np.testing.assert_array_equal(episode.alarm[:-1], above)
    assert len(episode.onsets) > 1
    assert all(episode.alarm[episode.onsets]) and not any(episode.alarm[episode.onsets - 1])
    # every manoeuvre starts on an alarm: the controller's own
    starts = np.flatnonzero(episode.manoeuvring & ~np.r_[False, episode.manoeuvring[:-1]])
    assert len(starts) and set(starts) <= set(episode.onsets)
    assert episode.outcome == "collided" and episode.collision_frame == n - 1


@pytest.mark.slow
def test_a_detector_can_drive_loom_steer_instead(tmp_path):
    assert demo_avoid.parse_avoider("lgmd1/robot-image,loom-steer") == (
        "lgmd1/robot-image", "loom-steer")
    ep = demo_avoid.drive(**{**SMALL, "detector": "lgmd1/robot-image"}, how="loom-steer")
    assert ep.how == "loom-steer" and len(ep.onsets) > 0
    # it avoids while excited: every avoidance starts on an alarm
    starts = np.flatnonzero(ep.manoeuvring & ~np.r_[False, ep.manoeuvring[:-1]])
    assert len(starts) and set(starts) <= set(ep.onsets)
    assert demo_avoid.figure(ep).get_suptitle().startswith(
        "loom-steer driven by lgmd1/robot-image: ")


def test_the_side_defaults_to_the_controllers(episode):
    from lgmd_sim.controllers.avoid import ReactiveParams

    assert demo_avoid.parse_avoider(" lgmd1 ") == ("lgmd1", ReactiveParams.side)
    assert episode.how == ReactiveParams.side  # drive() given none


def test_the_figure_marks_the_controllers_onsets_on_the_path_and_in_time(episode):
    fig = demo_avoid.figure(episode)
    top, trace = fig.axes[:2]
    marks = {ax: next(line for line in ax.get_lines() if line.get_label() == "alarm onset")
             for ax in (top, trace)}
    np.testing.assert_array_equal(np.c_[marks[top].get_data()], episode.path[episode.onsets])
    np.testing.assert_allclose(marks[trace].get_xdata(), episode.onsets / episode.fps)
    (hit,) = [line for line in top.get_lines() if line.get_label() == "collision"]
    np.testing.assert_array_equal(hit.get_xydata()[0], episode.path[episode.collision_frame])
    (goal,) = [line for line in top.get_lines() if line.get_label() == "goal"]
    np.testing.assert_array_equal(goal.get_xydata()[0], episode.view["goal"])
    title = fig.get_suptitle()
    assert f"seed {SMALL['seed']}" in title and "jitter 1" in title
    assert f"collided, {len(episode.onsets)} alarms" in title


def test_the_video_shows_every_frame_beside_the_map(episode, tmp_path):
    demo_avoid.write(episode, tmp_path / "avoid.mp4", tmp_path / "avoid.png")
    cap = cv2.VideoCapture(str(tmp_path / "avoid.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == len(episode.frames)
    ok, frame = cap.read()
    cap.release()
    h, w = episode.frames[0].shape[:2]
    assert ok and frame.shape[0] == demo_avoid.VIDEO_SCALE * h
    assert frame.shape[1] > demo_avoid.VIDEO_SCALE * w  # the map beside the camera view
    assert cv2.imread(str(tmp_path / "avoid.png")) is not None


@pytest.mark.slow
def test_a_failure_writing_the_avoiding_episode_leaves_no_file(tmp_path, monkeypatch):
    out = tmp_path / "d"
    written = demo_avoid.write

    def fail(ep, video, summary, *text):
        written(ep, video, summary, *text)
        raise OSError(28, "No space left on device", str(summary))

    monkeypatch.setattr(demo_avoid, "write", fail)
    with pytest.raises(OSError, match="No space left"):
        demo.run(out=out, detectors=["feedback/paper"], resolution="small",
                 avoider="lgmd1/calibrated-image", avoid_seed=3, avoid_resolution="small")
    assert [p for p in out.rglob("*") if p.is_file()] == []
