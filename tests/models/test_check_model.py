"""`check_model` and `lgmd-sim models --check`: the built-ins keep the model contract, and
each kind of broken model is caught with one line naming what is wrong."""

import re
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.core.params import in_range, param, tuple_of
from lgmd_sim.models import (
    LGMDModel,
    ModelCheckError,
    ModelParams,
    SearchRange,
    StateMap,
    check_model,
)
from lgmd_sim.models.check import CHECKS

SMALL = {"frames": 20, "size": (24, 32)}


@dataclass(frozen=True)
class TinyParams(ModelParams):
    decay: float = param(0.5, "test", check=in_range(0.0, 1.0),
                         doc="share of the excitation E kept from one frame to the next")


class Tiny(LGMDModel):
    """A valid test detector: E, a leaky sum of |frame changes|; the potential a sigmoid of
    its mean."""

    name = "tiny"
    Params = TinyParams
    layer_names = ("P", "E")

    def allocate(self, n, height, width):
        self._prev = np.zeros((n, height, width), np.uint8)
        self._e = np.zeros((n, height, width), np.float32)
        self._fresh = np.ones(n, bool)

    def reset_streams(self, idx):
        self._e[idx] = 0.0
        self._fresh[idx] = True

    def state_maps(self):
        return [StateMap("_prev", "frame"), StateMap("_e")]

    def step_batch(self, grey, layers):
        if grey.dtype != np.uint8 and self._prev.dtype == np.uint8:
            self._prev = self._prev.astype(np.float32)
        self._prev[self._fresh] = grey[self._fresh]
        self._fresh[:] = False
        p = np.abs(grey.astype(np.float32) - self._prev)
        self._prev[...] = grey
        self._e *= np.float32(self.params.decay)
        self._e += p
        if layers is not None:
            layers["P"][:] = p
            layers["E"][:] = self._e
        return 1.0 / (1.0 + np.exp(-self._e.mean(axis=(1, 2), dtype=np.float64) / 255.0))


# --- broken models: each breaks one part of the contract ----------------------------------


class Crosstalk(Tiny):
    """Every stream reports the batch's mean potential."""

    def step_batch(self, grey, layers):
        p = super().step_batch(grey, layers)
        return np.full_like(p, p.mean())


class Sticky(Tiny):
    """reset_streams keeps the stream's excitation."""

    def reset_streams(self, idx):
        self._fresh[idx] = True


class Unbounded(Tiny):
    """The potential runs from 0, below any threshold."""

    def step_batch(self, grey, layers):
        return 2.0 * super().step_batch(grey, layers) - 1.0


class NotFinite(Tiny):
    def step_batch(self, grey, layers):
        return super().step_batch(grey, layers) * np.nan


@dataclass(frozen=True)
class UnsourcedParams(TinyParams):
    scale: float = 1.0


class Unsourced(Tiny):
    Params = UnsourcedParams


@dataclass(frozen=True)
class UncheckedParams(TinyParams):
    scale: float = param(1.0, "test")


class Unchecked(Tiny):
    Params = UncheckedParams


class Hidden(Tiny):
    """E is state, but only the previous frame is declared."""

    def state_maps(self):
        return [StateMap("_prev", "frame")]


class Aliased(Tiny):
    """Returns a view of the array it writes every step's potentials into."""

    def allocate(self, n, height, width):
        super().allocate(n, height, width)
        self._k = np.zeros(n)

    def step_batch(self, grey, layers):
        self._k[:] = super().step_batch(grey, layers)
        return self._k[:]


class Noisy(Tiny):
    """Adds noise from an unseeded generator."""

    def step_batch(self, grey, layers):
        p = super().step_batch(grey, layers)
        return np.minimum(p + 1e-3 * np.random.default_rng().random(len(p)), 1.0)


class Unfilled(Tiny):
    """Never writes its layer E."""

    def step_batch(self, grey, layers):
        return super().step_batch(grey, layers and {**layers, "E": layers["E"].copy()})


class Resizing(Tiny):
    """Starts over on a frame of another size, without a reset."""

    def step(self, frame, **kwargs):
        if self.frame_shape is not None and np.shape(frame)[-2:] != self.frame_shape:
            self.frame_shape = None
        return super().step(frame, **kwargs)


class Stale(Tiny):
    """Steps on the previous frame of before the warp, not the one the base scaled."""

    def allocate(self, n, height, width):
        super().allocate(n, height, width)
        self._kept = self._prev

    def step_batch(self, grey, layers):
        self._prev = self._kept
        return super().step_batch(grey, layers)


class Unwarpable(Tiny):
    """Declares no state maps: it runs without front ends only, as the contract allows."""

    state_maps = LGMDModel.state_maps


@dataclass(frozen=True)
class PairedParams(TinyParams):
    pair: tuple[float, float] = param((0.2, 0.4), "test", check=tuple_of(in_range(0.0, 1.0), 2),
                                      doc="two shares")


class Tuned(Tiny):
    """Declares a search space: a parameter and both elements of a tuple parameter."""

    Params = PairedParams
    search_space: ClassVar[dict[str, SearchRange]] = {
        "pair[1]": SearchRange(0.1, 0.9), "decay": SearchRange(0.1, 0.9),
        "pair[0]": SearchRange(0.5, 1.0, log=False, times="pair[1]")}


class Unknown(Tuned):
    search_space: ClassVar[dict[str, SearchRange]] = {
        "decay": SearchRange(0.1, 0.9), "nosuch": SearchRange(0.1, 0.9)}


class HalfTuple(Tuned):
    search_space: ClassVar[dict[str, SearchRange]] = {"pair[1]": SearchRange(0.1, 0.9)}


class Mixed(Tuned):
    search_space: ClassVar[dict[str, SearchRange]] = {
        "pair": SearchRange(choices=((0.1, 0.2),)), "pair[0]": SearchRange(0.1, 0.9),
        "pair[1]": SearchRange(0.1, 0.9)}


class Indexed(Tuned):
    search_space: ClassVar[dict[str, SearchRange]] = {"decay[0]": SearchRange(0.1, 0.9)}


class OutOfRange(Tuned):
    search_space: ClassVar[dict[str, SearchRange]] = {"decay": SearchRange(1.5, 2.0)}


@pytest.mark.slow
def test_the_built_ins_pass():
    for name in models.available():
        assert check_model(name, **SMALL) == [(title, "passed") for title in CHECKS]


@pytest.mark.parametrize(("model", "skipped"), [
    (Tiny, {"search space": "skipped: no search_space"}),
    (Unwarpable, {"front ends": "skipped: no state_maps",
                  "search space": "skipped: no search_space"}),
    (Tuned, {}),
])
def test_a_valid_plug_in_passes_saying_what_it_skipped(model, skipped):
    assert check_model(model, **SMALL) == [(title, skipped.get(title, "passed"))
                                           for title in CHECKS]


@pytest.mark.parametrize(("spec", "message"), [
    ("lgmd1/nosuchpreset", "lgmd1/nosuchpreset: unknown preset 'nosuchpreset' for model "
                           "'lgmd1'; available: published"),
    ("lgmd1+nosuch", "lgmd1+nosuch: unknown front end(s) 'nosuch'; available: +pose"),
    ("eta_lgmd:EtaLGMD/nosuch", "eta_lgmd:EtaLGMD/nosuch: unknown preset 'nosuch' for model "
                                "'eta_lgmd:EtaLGMD'; available: gabbiani"),
    ("nosuch", "nosuch: unknown model 'nosuch'; available: feedback"),
])
@pytest.mark.usefixtures("examples_on_path")
def test_a_bad_preset_or_front_end_is_the_specs_fault(spec, message):
    with pytest.raises(ModelCheckError, match=re.escape(message)) as exc:
        check_model(spec, **SMALL)
    assert len(str(exc.value).splitlines()) == 1


@pytest.mark.parametrize(("model", "message"), [
    (int, "class: <class 'int'> is not a subclass of LGMDModel"),
    (Unsourced, "parameters: parameter scale has no source"),
    (Unchecked, "parameters: parameter scale has no check"),
    (Unbounded, "potentials: potential 0 at frame 0, stream 0, is outside the range the "
                "alarm threshold takes (a threshold must be a number in [0.5, 1.0])"),
    (NotFinite, "potentials: potential nan at frame 0, stream 0, is not finite"),
    (Aliased, "potentials: the potentials returned at frame 0 changed later"),
    (Noisy, "determinism: two fresh models give different potentials on the same frames"),
    (Unfilled, "layers: layer E at frame 0 is not filled in full"),
    (Crosstalk, "streaming = batched: stream 0 of a batch of 3 differs from the same frames "
                "run alone at frame 1"),
    (Sticky, "reset: after reset([1]) stream 1 differs from a fresh stream"),
    (Resizing, "frame size: a frame of another size was taken without reset()"),
    (Hidden, "front ends: state _e is frame-shaped but not declared in state_maps(), so the "
             "front ends cannot warp it"),
    (Stale, "front ends: a brightness gain (0.7) changes none of the outputs: the model does "
            "not read its scaled previous frame _prev"),
    (Unknown, "search space: model 'tiny': search_space key 'nosuch' is no parameter (or "
              "'parameter[i]') of the model"),
    (HalfTuple, "search space: model 'tiny': search_space keys pair[1]: name pair[0] to "
                "pair[1], each once"),
    (Mixed, "search space: model 'tiny': search_space keys pair, pair[0], pair[1]: name "
            "pair[0] to pair[1], each once"),
    (Indexed, "search space: model 'tiny': search_space keys decay[0]: name decay alone: its "
              "default is no tuple"),
    (OutOfRange, "search space: the candidate {'decay': 1."),
])
def test_a_broken_model_is_caught_in_one_line_naming_the_problem(model, message):
    with pytest.raises(ModelCheckError, match=re.escape(message)) as exc:
        check_model(model, **SMALL)
    assert str(exc.value).startswith(f"{model.__module__}:{model.__qualname__}: ")
    assert len(str(exc.value).splitlines()) == 1
    assert isinstance(exc.value, ValueError)




@pytest.mark.usefixtures("examples_on_path")
def test_a_slow_model_whose_reset_streams_does_nothing_is_caught():
    """The eta example is still at rest a third of the way into the checker's frames: a
    stream reset there says nothing, so the checker resets one late as well."""
    from eta_lgmd import EtaLGMD

    class Forgetful(EtaLGMD):
        def reset_streams(self, idx: np.ndarray) -> None:
            pass

    check_model(EtaLGMD)
    with pytest.raises(ModelCheckError, match=r"reset: after reset\(\[1\]\) stream 1 differs"):
        check_model(Forgetful)


class Layerless(Tiny):
    """A sound model that returns no maps."""

    layer_names = ()

    def step_batch(self, grey, layers):
        return super().step_batch(grey, None)


def test_a_model_without_layers_passes_and_gives_no_maps_when_asked():
    check_model(Layerless)
    out = Layerless().step(np.zeros((24, 32), np.uint8), layers=True)
    assert out.layers == {}
