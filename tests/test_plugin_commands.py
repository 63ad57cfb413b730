"""A researcher's model and controller, named by a "package.module:Class" spec, through
every command: detect, both benchmarks (the reactive controller driven by the plug-in
model, and a plug-in controller), and the calibration of the model's declared search
space; and the built-ins' search spaces, which draw the same candidates as before they
were declared by the models."""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
import re
import sys

import cv2
import pytest

from lgmd_sim import cli, controllers, models, options, stimuli
from lgmd_sim.calibration import search
from lgmd_sim.calibration.run import CalibrateConfig

# A small model with a search space, and one without: the potential is a sigmoid of the
# mean frame change.
MODEL = '''
from dataclasses import dataclass

import numpy as np

from lgmd_sim.models import LGMDModel, ModelParams
from lgmd_sim.models.base import SearchRange, StateMap
from lgmd_sim.params import in_range, param


@dataclass(frozen=True)
class BlinkParams(ModelParams):
    scale: float = param(20.0, "test", check=in_range(0.0, 1000.0), doc="gain of the change")


class Blink(LGMDModel):
    """A test detector: the potential rises with the mean frame change."""

    name = "blink"
    Params = BlinkParams
    layer_names = ("P",)
    presets = {"plain": {}, "fast": {"scale": 200.0}}
    search_space = {"scale": SearchRange(1.0, 500.0)}

    def allocate(self, n, height, width):
        self._prev = np.zeros((n, height, width), np.float32)
        self._fresh = np.ones(n, bool)

    def reset_streams(self, idx):
        self._fresh[idx] = True

    def state_maps(self):
        return [StateMap("_prev", "frame")]

    def step_batch(self, grey, layers):
        g = grey.astype(np.float32)
        self._prev[self._fresh] = g[self._fresh]
        self._fresh[:] = False
        p = np.abs(g - self._prev)
        self._prev = g
        if layers is not None:
            layers["P"][:] = p
        return 1.0 / (1.0 + np.exp(-self.params.scale * p.mean(axis=(1, 2)) / 255.0))


class Untuned(Blink):
    """The same, declaring nothing to search."""

    search_space = {}
'''

CONTROLLER = '''
from dataclasses import dataclass

import numpy as np

from lgmd_sim.controllers import Controller
from lgmd_sim.params import CheckedParams


@dataclass(frozen=True)
class CreepParams(CheckedParams):
    pass


class Creep(Controller):
    """Creeps forward."""

    Params = CreepParams

    def act(self, obs, info):
        return np.array([0.3, 0.0], np.float32)
'''

SPEC = "lgmdcmdplug.looming:Blink"
DRIVE = "lgmdcmdplug.drive:Creep"
QUIET = ["--workers", "1", "--no-progress"]


@pytest.fixture(scope="module", autouse=True)
def plugin(tmp_path_factory):
    """A package ``lgmdcmdplug`` on sys.path (of this process only: ``--workers 1``)."""
    root = tmp_path_factory.mktemp("plug")
    package = root / "lgmdcmdplug"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "looming.py").write_text(MODEL)
    (package / "drive.py").write_text(CONTROLLER)
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(root))
        yield root
    for name in [m for m in sys.modules if m.split(".")[0] == "lgmdcmdplug"]:
        del sys.modules[name]


@pytest.fixture
def fresh_models(monkeypatch):
    """Nothing registered, as the session began."""
    monkeypatch.setattr(models, "_MODELS", dataclasses.replace(models._MODELS, registered={}))


# --- the built-ins' spaces --------------------------------------------------------------

#: Candidates of the samplers calibration/search.py held before the models declared their
#: spaces (computed from that code), which the shipped calibrations were drawn by.
BEFORE = {
    ("feedback", 3, 0): [
        {},
        {"feedback_gain": 1.0398156861659777, "rho": 0.8678164004196114,
         "eta": (7.516638732078025, 11.501997761857227),
         "zeta": (0.705017392073565, 0.5726468923895662), "tv_window": 3,
         "k_mode": "constant", "mu": 0.44770185889610686},
        {"feedback_gain": 159.94037211296492, "rho": 0.39777882674210135,
         "eta": (1.1312673148866188, 3.38681018202749),
         "zeta": (0.9812616578600013, 0.5217120189511555), "tv_window": 12,
         "k_mode": "constant", "mu": 2.2126839439602985}],
    ("feedback-open-loop+imu", 3, 0): [
        {"feedback_gain": 0.0}, {"feedback_gain": 0.0, "mu": 9.41279072664345},
        {"feedback_gain": 0.0, "mu": 3.8430194685524515}],
    ("lgmd2+image", 3, 5): [{}, {"c_sig": 0.8048329420652817}, {"c_sig": 0.8203958674971054}],
    ("f_off", 2, 0): [{}, {"c_sig": 50.30763598189079}],
}
#: sha256 of every default detector's 32 candidates at seed 0 (parameters in order), from
#: the same code.
BEFORE_ALL = "e1fbd8a4ed363e64436e774ec07232bb7c07c8376fd59fd87c09bd4a1f644496"
DEFAULT_DETECTORS = [
    "feedback", "feedback-open-loop", "lgmd1", "lgmd2", "f_on", "f_off", "feedback+image",
    "feedback+imu", "feedback-open-loop+image", "feedback-open-loop+imu", "lgmd1+image",
    "lgmd1+imu", "lgmd2+image", "lgmd2+imu", "f_on+image", "f_on+imu", "f_off+image",
    "f_off+imu"]


def test_the_declared_spaces_draw_the_candidates_of_before():
    for (detector, budget, seed), params in BEFORE.items():
        got = [dict(c.params) for c in search.candidates(detector, budget, seed)]
        assert got == params, detector
        assert [list(p) for p in got] == [list(p) for p in params]  # in the same order
    assert search.detector_list() == DEFAULT_DETECTORS == list(CalibrateConfig().detectors)
    text = repr([(c.detector, c.index, list(c.params.items())) for d in DEFAULT_DETECTORS
                 for c in search.candidates(d, 32, 0)])
    assert hashlib.sha256(text.encode()).hexdigest() == BEFORE_ALL


# --- names and checks -------------------------------------------------------------------


def test_names_take_specs_and_refuse_bad_ones():
    known = controllers.available()
    load = controllers.controller_class
    assert options.names(f"straight,{DRIVE}", known, "controller(s)", load=load) == [
        "straight", DRIVE]
    with pytest.raises(ValueError, match=re.escape(f"unknown controller(s) '{DRIVE}'")):
        options.names(DRIVE, known, "controller(s)")  # no load: no spec
    with pytest.raises(ValueError, match="has no 'Nope'"):
        options.names("lgmdcmdplug.drive:Nope", known, "controller(s)", load=load)
    assert options.model_names(f"lgmd1,{SPEC}") == ["lgmd1", SPEC]
    with pytest.raises(ValueError, match="cannot import module 'nowhere'"):
        options.model_names("nowhere:Blink")


def test_the_reactive_controller_takes_a_spec():
    reactive = controllers.make("reactive", model=SPEC, preset="fast+image")
    assert type(reactive.params).__name__ == "ReactiveParams" and reactive.params.model == SPEC
    with pytest.raises(ValueError, match=r"parameter model='lgmdcmdplug\.looming:Nope'.*no 'Nope'"):
        controllers.make("reactive", model="lgmdcmdplug.looming:Nope")


def test_the_calibration_takes_a_model_that_declares_a_space(fresh_models):
    sp = search.space(f"{SPEC}+image")
    assert (sp.model, sp.preset, list(sp.ranges), sp.front) == (SPEC, "plain", ["scale"],
                                                                 "image")
    [first, second] = search.candidates(SPEC, 2, 0)
    assert first.params == {} and 1.0 <= second.params["scale"] <= 500.0
    assert first.key == "lgmdcmdplug.looming_Blink-000"  # a file name
    models.register("blink", SPEC)
    assert search.detector_list()[:7] == [*DEFAULT_DETECTORS[:6], "blink"]
    assert CalibrateConfig(detectors=("blink+imu", SPEC)).detectors == ("blink+imu", SPEC)
    untuned = "lgmdcmdplug.looming:Untuned"
    models.register("untuned", untuned)
    assert "untuned" not in search.detector_list()
    for detector in (untuned, "untuned+image"):
        with pytest.raises(ValueError, match="declares no search_space: the calibration has "
                                             "nothing to tune"):
            CalibrateConfig(detectors=(detector,))
    with pytest.raises(ValueError, match="front ends are \\+image, \\+imu"):
        search.space(f"{SPEC}+gain")


# --- the commands -----------------------------------------------------------------------


def test_detect_runs_a_spec(tmp_path):
    clip = stimuli.approaching((48, 64), start_distance=1.0, speed=2.0, still_frames=3,
                               look=stimuli.Look(background="texture"))
    video = tmp_path / "approach.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (64, 48))
    for f in clip.frames:
        writer.write(cv2.cvtColor(f, cv2.COLOR_GRAY2BGR))
    writer.release()
    out = tmp_path / "out"
    assert cli.main(["detect", str(video), "--models", f"lgmd1,{SPEC}", "--out", str(out),
                     "--no-progress"]) == 0
    rows = list(csv.DictReader((out / "approach.csv").open()))
    assert len(rows) == len(clip) and 0.5 <= float(rows[-1][f"{SPEC}_potential"]) < 1
    assert list(json.loads((out / "approach.json").read_text())["models"]) == ["lgmd1", SPEC]


def test_open_loop_bench_runs_a_spec_with_a_front_end(tmp_path):
    out = tmp_path / "open"
    assert cli.main(["bench", "open-loop", "--scenarios", "HandheldApproach", "--jitter", "1",
                     "--seeds", "1", "--models", f"{SPEC},{SPEC}/fast+image",
                     "--resolution", "small", "--noise-levels", "", *QUIET,
                     "--out", str(out)]) == 0
    rows = {r["detector"] for r in csv.DictReader((out / "summary.csv").open())}
    assert rows == {f"{SPEC}/plain", f"{SPEC}/fast+image"}


def test_closed_loop_bench_runs_a_spec_model_and_a_spec_controller(tmp_path):
    out = tmp_path / "closed"
    assert cli.main(["bench", "closed-loop", "--scenarios", "StationaryApproach", "--jitter",
                     "0", "--controllers", f"reactive,{DRIVE}", "--models", SPEC,
                     "--seeds", "1", "--resolution", "small", *QUIET, "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert {(r["controller"], r["model"]) for r in rows} == {("reactive", SPEC), (DRIVE, "")}
    assert not [p.name for p in (out / "records").iterdir() if ":" in p.name]


def test_calibrate_tunes_a_spec(tmp_path):
    out = tmp_path / "cal"
    assert cli.main(["calibrate", "--detectors", f"{SPEC},{SPEC}+image", "--budget", "2",
                     "--seeds", "1", "--resolution", "small", *QUIET, "--out", str(out)]) == 0
    presets = json.loads((out / "calibrated.json").read_text())["presets"][SPEC]
    assert set(presets) == {"calibrated", "calibrated-image"}
    assert presets["calibrated"]["from"] == "plain"
    assert presets["calibrated-image"]["params"]["stabilize"] == "image"
    assert not [p.name for p in (out / "records").iterdir() if ":" in p.name]
