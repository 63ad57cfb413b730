"""A researcher's model and controller, named by a "package.module:Class" spec, through
every command: detect, both benchmarks (the reactive controller driven by the plug-in
model, and a plug-in controller), and the calibration of the model's declared search
space; and the built-ins' search spaces, which draw the same candidates as before they
were declared by the models."""

from __future__ import annotations

import csv
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import cli, controllers, models
from lgmd_sim.benchmark import entries
from lgmd_sim.calibration import search
from lgmd_sim.calibration.run import CalibrateConfig
from lgmd_sim.controllers import options
from lgmd_sim.envs.wrappers import LGMDFeatures

#: --config files of the commands' research keys.
KEYS = Path(__file__).parent / "keys"
#: bench open-loop without the noisy copies of the clips.
NO_NOISE = ["--config", str(KEYS / "no-noise.toml")]

# The plug-in, tests/plugins/lgmd_plug.py, by its specs: a model with a search space, the
# same without one ("Untuned"), and a controller.
SPEC = "lgmd_plug:Blink"
DRIVE = "lgmd_plug:Creep"
QUIET = ["--workers", "1", "--no-progress"]


@pytest.fixture(scope="module", autouse=True)
def plugin():
    """tests/plugins on sys.path (of this process only: ``--workers 1``)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(Path(__file__).resolve().parents[1] / "plugins"))
        yield


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
#: sha256 of every default detector's 32 candidates at seed 0 (parameters in order, each
#: number to 12 significant digits), from the same code. Not to the last bit: log-uniform
#: draws go through numpy's exp, whose SIMD loops differ in the last bit from one CPU to
#: another (AVX-512 against AVX2 machines).
BEFORE_ALL = "19a420a3fde6c7aa60a6938e05399c0afb6c08db67e3368efd766263246d61ba"
DEFAULT_DETECTORS = [
    "feedback", "feedback-open-loop", "lgmd1", "lgmd2", "f_on", "f_off", "feedback+image",
    "feedback+imu", "feedback-open-loop+image", "feedback-open-loop+imu", "lgmd1+image",
    "lgmd1+imu", "lgmd2+image", "lgmd2+imu", "f_on+image", "f_on+imu", "f_off+image",
    "f_off+imu"]


def _digits(value: object) -> object:
    """A parameter with its numbers to 12 significant digits."""
    if isinstance(value, float):
        return f"{value:.12g}"
    return tuple(map(_digits, value)) if isinstance(value, tuple) else value


def _built_in(detector: str) -> bool:
    head = detector.partition("+")[0]
    return models.origin(search.CONTROLS.get(head, (head,))[0]) == "built-in"


def test_the_declared_spaces_draw_the_candidates_of_before():
    for (detector, budget, seed), params in BEFORE.items():
        got = [dict(c.params) for c in search.candidates(detector, budget, seed)]
        assert [{k: _digits(v) for k, v in p.items()} for p in got] == [
            {k: _digits(v) for k, v in p.items()} for p in params], detector
        assert [list(p) for p in got] == [list(p) for p in params]  # in the same order
    # the built-ins' only: an installed distribution's model may declare a space too
    assert [d for d in search.detector_list() if _built_in(d)] == DEFAULT_DETECTORS
    assert [d for d in CalibrateConfig().detectors if _built_in(d)] == DEFAULT_DETECTORS
    text = repr([(c.detector, c.index, [(k, _digits(v)) for k, v in c.params.items()])
                 for d in DEFAULT_DETECTORS for c in search.candidates(d, 32, 0)])
    assert hashlib.sha256(text.encode()).hexdigest() == BEFORE_ALL


# --- names and checks -------------------------------------------------------------------


def test_names_take_specs_and_refuse_bad_ones():
    assert options.controller_names(f"straight,{DRIVE}") == ["straight", DRIVE]
    with pytest.raises(ValueError, match=re.escape(f"unknown controller(s) '{DRIVE}'")):
        options.names(DRIVE, controllers.available(), "controller(s)")  # no load: no spec
    with pytest.raises(ValueError, match="has no 'Nope'"):
        options.controller_names("lgmd_plug:Nope")
    with pytest.raises(ValueError, match=re.escape("unknown controller 'drive'")):
        options.controller_names("drive", "controller")
    assert options.model_names(f"lgmd1,{SPEC}") == ["lgmd1", SPEC]
    with pytest.raises(ValueError, match="cannot import module 'nowhere'"):
        options.model_names("nowhere:Blink")


def test_the_reactive_controller_takes_a_spec():
    reactive = controllers.make("reactive", model=SPEC, preset="fast+image")
    assert type(reactive.params).__name__ == "ReactiveParams" and reactive.params.model == SPEC
    with pytest.raises(ValueError, match=r"parameter model='lgmd_plug:Nope'.*no 'Nope'"):
        controllers.make("reactive", model="lgmd_plug:Nope")


def test_halves_reads_a_plug_ins_last_layer_and_turns_away_from_the_changing_half():
    """A model without an S layer: side='halves' compares its last layer's halves (Blink's
    P), so a change on the left turns the robot right (> 0: the threat on the left)."""
    reactive = controllers.make("reactive", model=SPEC, preset="fast", side="halves")
    reactive.reset()
    still = np.full((24, 32, 3), 128, np.uint8)
    assert reactive._trigger({"frame": still}, {"time": 0.0}) is None
    moved = still.copy()
    moved[:, :10] = 255  # the left third brightens
    side = reactive._trigger({"frame": moved}, {"time": 0.1})
    assert side is not None and side > 0


def test_halves_refuses_a_model_without_layers_in_one_line(fresh_registries):
    class Layerless(models.model_class(SPEC)):
        layer_names = ()

    models.register("layerless", Layerless)
    with pytest.raises(ValueError, match=r"side='halves'.*layerless has none.*side='eyes'"):
        controllers.make("reactive", model="layerless", side="halves")
    assert controllers.make("reactive", model="layerless", side="eyes") is not None


def test_the_calibration_takes_a_model_that_declares_a_space(fresh_registries):
    sp = search.space(f"{SPEC}+image")
    assert (sp.model, sp.preset, list(sp.ranges), sp.front) == (SPEC, "plain", ["scale"],
                                                                 "image")
    [first, second] = search.candidates(SPEC, 2, 0)
    assert first.params == {} and 1.0 <= second.params["scale"] <= 500.0
    assert first.key == "lgmd_plug_Blink-000"  # a file name
    models.register("blink", SPEC)
    assert search.detector_list()[:7] == [*DEFAULT_DETECTORS[:6], "blink"]
    assert CalibrateConfig(detectors=("blink+imu", SPEC)).detectors == ("blink+imu", SPEC)
    untuned = "lgmd_plug:Untuned"
    models.register("untuned", untuned)
    assert "untuned" not in search.detector_list()
    for detector in (untuned, "untuned+image"):
        with pytest.raises(ValueError, match="declares no search_space: the calibration has "
                                             "nothing to tune"):
            CalibrateConfig(detectors=(detector,))
    with pytest.raises(ValueError, match="front ends are \\+image, \\+imu"):
        search.space(f"{SPEC}+gain")


# --- the commands -----------------------------------------------------------------------


def test_detect_runs_a_spec(approach, tmp_path):
    video, clip = approach
    out = tmp_path / "out"
    assert cli.main(["detect", str(video), "--models", f"lgmd1,{SPEC}", "--out", str(out),
                     "--no-progress"]) == 0
    rows = list(csv.DictReader((out / "approach.csv").open()))
    assert len(rows) == len(clip)
    # above rest on every frame the disc grows (the clip ends still: it fills the frame)
    growing = np.abs(np.diff(clip.frames.astype(float), axis=0)).mean(axis=(1, 2)) > 1
    potentials = np.array([float(r[f"{SPEC}_potential"]) for r in rows[1:]])
    assert growing.sum() >= 10 and (potentials[growing] > 0.5).all()
    assert list(json.loads((out / "approach.json").read_text())["models"]) == ["lgmd1", SPEC]


@pytest.mark.parametrize(("models_arg", "stabilize", "message"), [
    ("lgmd_plug:NoMaps", "image", "nomaps lists no state maps (state_maps), so it runs "
                                  "without front ends only: stabilize 'none', gain off"),
    (f"lgmd1,{SPEC}/nope", "none", f"unknown preset 'nope' for model '{SPEC}'"),
    (f"{SPEC}/fast+image", "gain", f"detector '{SPEC}/fast+image' names its front ends and "
                                   "--stabilize gives every model its own"),
])
def test_detect_refuses_in_one_line(approach, tmp_path, capsys, models_arg, stabilize,
                                    message):
    assert cli.main(["detect", str(approach[0]), "--models", models_arg, "--stabilize",
                     stabilize, "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_detect_takes_a_spec_with_its_preset_and_front_end(approach, tmp_path, capsys):
    """MODEL/PRESET+FRONT in --models, as everywhere: the plug-in at preset fast with the
    rotation fitted from the frames, at the camera's --fov."""
    assert cli.main(["detect", str(approach[0]), "--models", f"lgmd1,{SPEC}/fast+image",
                     "--fov", "40", "--json", "--no-progress"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert list(record["models"]) == ["lgmd1", f"{SPEC}/fast+image"]
    got = record["models"][f"{SPEC}/fast+image"]
    assert (got["stabilize"], got["fovy"]) == ("image", 40.0)


# --- a plug-in without an S layer, or without layers ---------------------------------------

BARE = "lgmd_plug:Bare"


def _brighter_left(features: LGMDFeatures) -> np.ndarray:
    """The features' grid after a still frame, then one whose left third brightens."""
    still = np.full((1, 24, 32, 3), 128, np.uint8)
    features.step(still, np.array([True]))
    moved = still.copy()
    moved[:, :, :10] = 255
    features.step(moved, np.array([False]))
    return features.observation({})["lgmd_grid"][0]


def test_the_features_grid_reads_a_plug_ins_last_layer_without_an_s_layer():
    """Blink has a P layer and no S: the grid shares out its P, so a change on the left
    is the left cell's (it was a KeyError 'S' at the first frame: lgmd-sim train)."""
    grid = _brighter_left(LGMDFeatures(1, SPEC, grid=(1, 2), keep_frame=False))
    assert grid[0] == pytest.approx(1.0) and grid[1] == pytest.approx(0.0)


def test_the_features_refuse_a_model_without_layers_when_made_unless_without_a_grid():
    with pytest.raises(ValueError) as exc:
        LGMDFeatures(1, BARE, grid=(1, 3))
    assert str(exc.value) == (
        f"the grid shares out the activity of a layer of the model (S, or a plug-in's "
        f"last), and {BARE} has none (layer_names is empty): grid=None observes its "
        "potentials and alarm alone")
    features = LGMDFeatures(1, BARE, grid=None, keep_frame=False)
    assert set(features.spaces) == {"lgmd_potential", "lgmd_alarm"}


def test_train_refuses_a_model_without_layers_before_its_run_folder(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    out = tmp_path / "run"
    assert cli.main(["train", "--model", BARE, "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(
        "lgmd-sim train: error: --obs features observes a grid of the activity of a layer "
        f"of the model (S, or a plug-in's last), and {BARE} has none")
    assert "--obs pixels or privileged" in err and not out.exists()


def test_benchmark_refuses_a_model_without_layers_at_the_default_side_before_any_entry(
        tmp_path, capsys):
    """The reference controller's default side reads a layer's halves: a model without
    layers is refused with every entry checked, before straight runs, in the CLI's
    spelling (@eyes), and no folder is made."""
    out = tmp_path / "out"
    assert cli.main(["benchmark", "straight", BARE, "--out", str(out), *QUIET]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"lgmd-sim benchmark: error: entry '{BARE}': the reference controller "
                   "tells the threat's side by the left and right halves of a layer of the "
                   f"model (S, or a plug-in's last), and {BARE} has none (layer_names is "
                   f"empty): give it two LGMDs, {BARE}@eyes")
    assert not out.exists()
    eyes = entries.parse(f"{BARE}@eyes")  # what it says to give: two LGMDs need no layer
    assert (eyes.kind, eyes.controller, eyes.side) == ("detector", "reactive", "eyes")
    assert controllers.make("reactive", model=BARE, side="eyes") is not None


def test_eval_refuses_the_policy_controller_by_spec_as_by_name():
    from lgmd_sim.training.evaluate import EvalConfig

    for given in ("policy", "lgmd_sim.controllers.policy:Policy"):
        with pytest.raises(ValueError, match=re.escape(f"unknown controller(s) '{given}'")):
            EvalConfig(controllers=(given,))


def test_open_loop_bench_runs_a_spec_with_a_front_end(tmp_path):
    out = tmp_path / "open"
    assert cli.main(["bench", "open-loop", "--scenarios", "HandheldApproach", "--jitter", "1",
                     "--seeds", "1", "--models", f"{SPEC},{SPEC}/fast+image",
                     "--resolution", "small", *NO_NOISE, *QUIET,
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


@pytest.mark.slow
def test_calibrate_tunes_a_spec(tmp_path):
    out = tmp_path / "cal"
    assert cli.main(["calibrate", "--detectors", f"{SPEC},{SPEC}+image", "--budget", "2",
                     "--seeds", "1", "--resolution", "small", *QUIET, "--out", str(out)]) == 0
    presets = json.loads((out / "calibrated.json").read_text())["presets"][SPEC]
    assert set(presets) == {"calibrated", "calibrated-image"}
    assert presets["calibrated"]["from"] == "plain"
    assert presets["calibrated-image"]["params"]["stabilize"] == "image"
    assert not [p.name for p in (out / "records").iterdir() if ":" in p.name]
