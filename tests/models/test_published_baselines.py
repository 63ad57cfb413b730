"""The ``published`` presets (and LGMD1's other published presets) against readable ports of
the published code (`lgmd_sim.models.reference.published`), on synthetic stimuli and on a
simulated hand-held jitter clip: membrane potentials within 1e-4."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim  # noqa: F401  (registers the environments)
from lgmd_sim import models
from lgmd_sim.core.frames import to_grey
from lgmd_sim.models.reference.published import ORACLES, olgmd
from lgmd_sim.signals import stimuli

SHAPE = (60, 80)


@pytest.fixture(scope="module")
def clips() -> dict[str, np.ndarray]:
    """Looming squares (dark, light, light on texture, faint dark on texture), a jittered
    translation, and a hand-held approach to a balloon rendered by the simulator."""
    env = gym.make("lgmd_sim/HandheldApproach-v0", jitter=1.0, resolution=SHAPE)
    obs, _ = env.reset(seed=0)
    frames = [to_grey(obs["frame"])]
    while len(frames) < 60:
        obs, _, terminated, truncated, _ = env.step([1.0, 0.0])
        frames.append(to_grey(obs["frame"]))
        if terminated or truncated:
            break
    env.close()
    return {
        "dark": stimuli.approaching(
            SHAPE, look=stimuli.Look(polarity="dark", contrast=0.3)).frames,
        "light": stimuli.approaching(
            SHAPE, look=stimuli.Look(polarity="light", contrast=0.3)).frames,
        "light on texture": stimuli.approaching(
            SHAPE, look=stimuli.Look(polarity="light", background="texture")).frames,
        "faint dark on texture": stimuli.approaching(
            SHAPE, look=stimuli.Look(contrast=0.1, background="texture")).frames,
        "jittered translation": stimuli.jittered(
            stimuli.translating(SHAPE, speed=2.0, still_frames=2), 0.5, seed=1).frames,
        "hand-held jitter": np.stack(frames),
    }


@pytest.mark.parametrize(("name", "preset", "params", "oracle", "kwargs", "label"), ORACLES,
                         ids=[f"{o[0]}-{o[5]}" for o in ORACLES])
def test_preset_matches_the_published_code(clips, name, preset, params, oracle, kwargs,
                                           label) -> None:
    exercised = 0
    for clip_name, frames in clips.items():
        model = models.make(name, preset=preset, **params)
        ours = np.array([model.step(f).potential for f in frames])
        theirs = oracle(frames, **kwargs)
        assert ours.shape == theirs.shape
        diff = np.abs(ours - theirs)
        assert diff.max() < 1e-4, f"{label}, {clip_name}: {diff.max():.2e} at {diff.argmax()}"
        exercised += int(((theirs > 0.51) & (theirs < 0.99)).sum())
    assert exercised >= 50  # away from rest and saturation, where differences would show


def test_the_olgmd_pm_off_bug_is_a_switch_that_matters(clips) -> None:
    frames = clips["hand-held jitter"]
    as_written = olgmd(frames)
    fixed = olgmd(frames, pm_off_from_on_mean=False)
    assert np.abs(as_written - fixed).max() > 0.01
    buggy = models.make("f_off", pm_off_uses_on_mean=True)
    np.testing.assert_allclose([buggy.step(f).potential for f in frames], as_written,
                               atol=1e-4)
