"""The worked example of a model of one's own, examples/eta_lgmd.py (the eta function of
the LGMD, Gabbiani et al. 1999), used by its spec as a researcher would use theirs
(docs/guides/own-detector.md)."""

import numpy as np
import pytest

from lgmd_sim import models

SPEC = "eta_lgmd:EtaLGMD"
SIZE = 128  # the model wants frames of 128 pixels or more (its docstring, "Limits")
FOCAL = SIZE / (2 * np.tan(np.radians(55.0) / 2))  # pixels, at the default fovy

pytestmark = pytest.mark.usefixtures("examples_on_path")


def _disc(radius: float, x: float) -> np.ndarray:
    """A hard-edged dark disc (grey 40) on a light background (grey 200), uint8, centred
    at column `x` of the middle row."""
    ys, xs = np.mgrid[:SIZE, :SIZE] + 0.5
    inside = (ys - SIZE / 2) ** 2 + (xs - x) ** 2 <= radius**2
    return np.where(inside, 40, 200).astype(np.uint8)


# An object of half-size l approaching at speed v, at l/|v| = 10 frames (1/3 s at 30
# fps), from 5 pixels of radius: its image radius is FOCAL tan(theta / 2) = FOCAL l / (v
# (T - t)), collision at frame T.
L_OVER_V, T = 10, int(FOCAL * 10 / 5)
RADII = FOCAL * L_OVER_V / (T - np.arange(T - 10))
FILLS = int(np.argmax(RADII >= SIZE / 2))  # the first frame the disc reaches the edges
THRESHOLD_FRAME = T - L_OVER_V * 4.5  # theta = 2 atan(1 / alpha) at the default alpha 4.5


def _looming() -> np.ndarray:
    return np.stack([_disc(r, SIZE / 2) for r in RADII[:FILLS]])


def _translating() -> np.ndarray:
    """The disc at the threshold angle's size (27 pixels of radius), crossing at 1.5 pixels
    a frame, inside the frame throughout."""
    return np.stack([_disc(FOCAL / 4.5, 32 + 1.5 * t) for t in range(40)])


def _potentials(frames: np.ndarray, preset: str = "gabbiani") -> np.ndarray:
    m = models.make(SPEC, preset=preset)
    return np.array([m.step(f).potential for f in frames])


def test_by_spec_with_its_preset_and_a_front_end():
    assert models.parse_spec(SPEC) == (SPEC, "gabbiani")
    name, preset = models.parse_spec(f"{SPEC}/gabbiani+image")
    assert (name, preset) == (SPEC, "gabbiani+image")
    m = models.make(name, preset=preset)
    assert (m.params.stabilize, m.params.alpha, m.params.delta) == ("image", 4.5, 1)
    out = m.step(_looming()[0], layers=True)
    assert out.potential == 0.5 and out.layers["P"].shape == (SIZE, SIZE)


def test_it_peaks_on_an_approach_and_stays_at_rest_on_a_recession_and_a_crossing():
    """Measured: over the looming disc's 226 frames (5 to 61 pixels of radius, the edges
    reached on the next frame) the potential first crosses the threshold 0.8 at frame 164,
    36 frames before the disc reaches the threshold angle (frame 200: the eta function's
    own rise, 0.8 being 70% of its peak) and 62 before it fills the frame; it peaks at 0.88
    on frame 206 (delta 1 and the low-pass's lag); before frame 100, pixel steps of the
    small disc lift it to 0.72 at most. With the "+image" front end: the first alarm on the
    same frame, the peak 0.89 on frame 217. The same frames played backwards and the
    crossing disc leave it at rest, 0.5 (to 1e-14): theta does not grow."""
    looming = _potentials(_looming())
    first_alarm, peak = int(np.argmax(looming > 0.8)), int(looming.argmax())
    assert looming.max() > 0.85 and looming[:20].max() == 0.5
    assert THRESHOLD_FRAME - 45 < first_alarm < FILLS - 40
    assert THRESHOLD_FRAME < peak < THRESHOLD_FRAME + 10 < FILLS
    assert _potentials(_looming()[::-1]).max() < 0.55
    assert _potentials(_translating()).max() < 0.55
    with_front_end = _potentials(_looming(), "gabbiani+image")
    assert int(np.argmax(with_front_end > 0.8)) == first_alarm and with_front_end.max() > 0.85


def test_streaming_equals_batched_bit_for_bit():
    looming, crossing = _looming()[150:190], _translating()
    batch = models.make(SPEC, preset="gabbiani+image", n_streams=2)
    one = [models.make(SPEC, preset="gabbiani+image") for _ in range(2)]
    for a, b in zip(looming, crossing, strict=True):
        out = batch.step(np.stack([a, b]), layers=True)
        for i, frame in enumerate((a, b)):
            single = one[i].step(frame, layers=True)
            assert out.potential[i] == single.potential and out.alarm[i] == single.alarm
            assert np.array_equal(out.layers["P"][i], single.layers["P"])


def test_reset_restores_a_new_stream():
    frames = _looming()[150:200]
    fresh = _potentials(frames)
    m = models.make(SPEC)
    for f in frames[:30]:
        m.step(f)
    m.reset()
    assert np.array_equal([m.step(f).potential for f in frames], fresh)
    batch = models.make(SPEC, n_streams=2)
    for f in frames[:30]:
        batch.step(np.stack([f, f]))
    batch.reset([1])
    again = np.array([batch.step(np.stack([f, f])).potential for f in frames])
    assert np.array_equal(again[:, 1], fresh) and not np.array_equal(again[:, 0], fresh)


def test_it_keeps_the_contract_and_declares_a_search_space():
    from lgmd_sim.calibration.search import space

    assert {result for _, result in models.check_model(f"{SPEC}/gabbiani+image")} == {"passed"}
    assert list(space(SPEC).ranges) == ["alpha", "c", "tau"]
