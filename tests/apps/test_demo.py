"""`lgmd-sim demo`: several detectors on one episode, the video, the summary and the
still written, and a bad detector refused before the episode runs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.apps import demo


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
    from lgmd_sim.core.pngtext import png_text, read_config

    text = png_text("lgmd-sim demo --seed 0", {"seed": 0})
    demo.write_video(episode, tmp_path / "demo.mp4", tmp_path / "demo_frame.png", text)
    demo.write_summary(episode, tmp_path / "demo.png", "test", text)
    for png in ("demo_frame.png", "demo.png"):  # each records what made it
        assert read_config(tmp_path / png) == ("lgmd-sim demo --seed 0", {"seed": 0})
    cap = cv2.VideoCapture(str(tmp_path / "demo.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == len(episode.frames)
    cap.release()
    still = cv2.imread(str(tmp_path / "demo_frame.png"))
    h, w = episode.frames[0].shape[:2]
    zoom = demo.SHOWN_HEIGHT // h  # a small camera is shown enlarged, by a whole factor
    assert zoom > 1 and still.shape == (zoom * h + demo.TRACE_HEIGHT, 2 * zoom * w, 3)
    assert np.array_equal(still[:zoom * h:zoom, :zoom * w:zoom],
                          cv2.cvtColor(episode.frames[episode.before_collision],
                                       cv2.COLOR_RGB2BGR))
    assert (tmp_path / "demo.png").stat().st_size > 20_000


def test_the_demo_s_two_variants_of_one_model_are_told_apart_by_colour():
    from lgmd_sim.core.plots import model_style

    calibrated, paper = (model_style(d)["color"] for d in demo.run.__kwdefaults__["detectors"])
    assert calibrated != paper
