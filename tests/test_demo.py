"""`lgmd-sim demo`: several detectors on one episode, the video, the summary and the
still written, and a bad detector refused before the episode runs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lgmd_sim import cli, demo, models


@pytest.fixture(scope="module")
def episode():
    return demo.drive(0, 1.0, ["lgmd1/published+image", "feedback/paper"], resolution="small")


def test_every_detector_watches_the_same_episode(episode):
    n = len(episode.frames)
    assert n > 30 and list(episode.potentials) == ["lgmd1/published+image", "feedback/paper"]
    assert all(p.shape == (n,) for p in episode.potentials.values())
    assert len(episode.s_layers) == n
    assert episode.thresholds["feedback/paper"] == models.make("feedback",
                                                               preset="paper").params.threshold
    # the stabilized model is not the plain one: the front end changed what it saw
    plain = demo.drive(0, 1.0, ["lgmd1/published"], resolution="small")
    assert not np.array_equal(plain.potentials["lgmd1/published"],
                              episode.potentials["lgmd1/published+image"])


def test_video_summary_and_still(episode, tmp_path):
    demo.write_video(episode, tmp_path / "demo.mp4", tmp_path / "demo_frame.png")
    demo.write_summary(episode, tmp_path / "demo.png", "test")
    cap = cv2.VideoCapture(str(tmp_path / "demo.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == len(episode.frames)
    cap.release()
    still = cv2.imread(str(tmp_path / "demo_frame.png"))
    h, w = episode.frames[0].shape[:2]
    assert still.shape == (h + demo.TRACE_HEIGHT, 2 * w, 3)
    assert (tmp_path / "demo.png").stat().st_size > 20_000


def test_an_unknown_detector_is_refused_before_the_episode(tmp_path, capsys):
    assert cli.main(["demo", "--models", "lgmd2/nope", "--out", str(tmp_path / "d")]) == 2
    assert "unknown preset 'nope'" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()
