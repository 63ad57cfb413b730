"""A researcher's own models and controllers: by a "package.module:Class" spec, by
`register`, and by an installed distribution's entry point."""

import dataclasses
import sys

import numpy as np
import pytest

from lgmd_sim import cli, controllers, models
from lgmd_sim.bench.episode import Cell, plan

# A small but complete model: the potential is a sigmoid of the mean frame change.
MODEL = '''
from dataclasses import dataclass

import numpy as np

from lgmd_sim.models import LGMDModel, ModelParams
from lgmd_sim.models.base import StateMap
from lgmd_sim.params import in_range, param


@dataclass(frozen=True)
class MineParams(ModelParams):
    scale: float = param(1.0, "test", check=in_range(0.0, 100.0), doc="gain of the change")


class Mine(LGMDModel):
    """A test detector: the potential rises with the mean frame change."""

    name = "mine"
    Params = MineParams
    layer_names = ("P",)
    presets = {"plain": {}, "fast": {"scale": 40.0}}

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
'''

CONTROLLER = '''
from dataclasses import dataclass

import numpy as np

from lgmd_sim.controllers import Controller
from lgmd_sim.params import CheckedParams


@dataclass(frozen=True)
class HaltParams(CheckedParams):
    pass


class Halt(Controller):
    """Stands still."""

    Params = HaltParams

    def act(self, obs, info):
        return np.zeros(2, np.float32)
'''


@pytest.fixture(autouse=True)
def fresh_registries(monkeypatch):
    """Each test starts from the built-ins: nothing registered, entry points read afresh,
    and no plug-in module of another test imported."""
    monkeypatch.setattr(models, "_MODELS", dataclasses.replace(models._MODELS, registered={}))
    monkeypatch.setattr(controllers, "_CONTROLLERS",
                        dataclasses.replace(controllers._CONTROLLERS, registered={}))
    yield
    for name in [m for m in sys.modules if m.split(".")[0].startswith("lgmdplug")]:
        del sys.modules[name]


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """A package ``lgmdplug`` on sys.path: ``lgmdplug.looming`` holds the model ``Mine``,
    ``lgmdplug.drive`` the controller ``Halt``."""
    package = tmp_path / "lgmdplug"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "looming.py").write_text(MODEL)
    (package / "drive.py").write_text(CONTROLLER)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def _looming(n: int = 6, size: tuple[int, int] = (24, 32)) -> np.ndarray:
    """A dark square growing on a textured background, uint8 (n, H, W)."""
    rng = np.random.default_rng(0)
    frames = np.repeat(rng.integers(100, 200, size, np.uint8)[None], n, axis=0)
    for t in range(n):
        r = 2 + 2 * t
        cy, cx = size[0] // 2, size[1] // 2
        frames[t, cy - r:cy + r, cx - r:cx + r] = 10
    return frames


def test_a_model_by_spec_with_a_preset_and_a_front_end(plugin):
    spec = "lgmdplug.looming:Mine"
    assert models.parse_spec(f"{spec}/fast+image") == (spec, "fast+image")
    assert models.parse_spec(spec) == (spec, "plain")
    name, preset = models.parse_spec(f"{spec}/fast+image")
    m = models.make(name, preset=preset)
    assert (m.params.scale, m.params.stabilize) == (40.0, "image")
    outs = [m.step(f, layers=True) for f in _looming()]
    assert all(0.5 <= o.potential < 1.0 for o in outs) and outs[-1].potential > 0.5
    assert outs[-1].layers["P"].shape == (24, 32)
    batch = models.make(spec, preset="fast", n_streams=2)
    out = batch.step(np.stack([_looming()[1]] * 2))
    assert out.potential.shape == (2,)
    assert list(models.presets_of(spec)) == ["plain", "fast"]


@pytest.mark.parametrize(("spec", "message"), [
    ("lgmdplug_absent.looming:Mine", "cannot import module 'lgmdplug_absent.looming'"),
    ("lgmdplug.looming:Nope", "module 'lgmdplug.looming' has no 'Nope'"),
    ("lgmdplug.looming:MineParams", "is not a subclass of lgmd_sim.models.base.LGMDModel"),
    ("lgmdplug.looming:np", "is not a subclass"),
    ("mine", "unknown model 'mine'; available: feedback"),
])
def test_a_bad_spec_is_a_one_line_error_naming_it(plugin, spec, message):
    with pytest.raises(ValueError, match=message) as exc:
        models.parse_spec(f"{spec}/fast")
    assert len(str(exc.value).splitlines()) == 1 and spec in str(exc.value)


def test_register_by_class_and_by_string(plugin):
    from lgmdplug.looming import Mine

    models.register("mine", Mine)
    models.register("mine_later", "lgmdplug.looming:Mine")  # imported on first use
    assert models.available()[-2:] == ["mine", "mine_later"]
    assert models.origin("mine") == "registered"
    assert models.model_class("mine_later") is Mine
    assert models.parse_spec("mine_later/fast+gain") == ("mine_later", "fast+gain")
    assert models.make("mine", preset="fast").params.scale == 40.0


@pytest.mark.parametrize(("name", "cls", "message"), [
    ("feedback", "lgmdplug.looming:Mine", "model name 'feedback' is taken \\(built-in\\)"),
    ("mine", dict, "model 'mine': <class 'dict'> is not a subclass"),
    ("my:mine", "lgmdplug.looming:Mine", "a model name is a non-empty string without"),
    ("mine/fast", "lgmdplug.looming:Mine", "a model name is a non-empty string without"),
    ("mine", "lgmdplug.looming.Mine", "is not a 'package.module:Class' string"),
])
def test_register_refuses(plugin, name, cls, message):
    with pytest.raises(ValueError, match=message):
        models.register(name, cls)
    assert name not in models.available()[5:]


def test_a_name_is_taken_once(plugin):
    models.register("mine", "lgmdplug.looming:Mine")
    with pytest.raises(ValueError, match="'mine' is taken \\(registered\\)"):
        models.register("mine", "lgmdplug.looming:Mine")


def test_an_installed_distributions_models_are_listed(tmp_path, monkeypatch, capsys):
    (tmp_path / "lgmdplug_ep.py").write_text(MODEL)
    info = tmp_path / "myplug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: myplug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[lgmd_sim.models]\nmyplug_mine = lgmdplug_ep:Mine\n")
    monkeypatch.syspath_prepend(str(tmp_path))

    assert models.available() == ["feedback", "lgmd1", "lgmd2", "f_on", "f_off",
                                  "myplug_mine"]
    assert models.origin("myplug_mine") == "entry point of myplug"
    assert models.make("myplug_mine", preset="fast+image").params.stabilize == "image"
    with pytest.raises(ValueError, match="taken \\(entry point of myplug\\)"):
        models.register("myplug_mine", "lgmdplug_ep:Mine")
    assert cli.main(["models"]) == 0
    out = capsys.readouterr().out
    assert ("myplug_mine: A test detector: the potential rises with the mean frame change. "
            "(entry point of myplug)") in out
    assert "presets: plain, fast (default plain)" in out and "scale = 1.0  [test]" in out


def test_a_controller_by_spec_and_by_name(plugin):
    from lgmdplug.drive import Halt

    assert isinstance(controllers.make("lgmdplug.drive:Halt"), Halt)
    controllers.register("halt", Halt)
    assert controllers.available()[-1] == "halt"
    assert controllers.controller_class("halt") is Halt
    for name, cls, message in [("straight", Halt, "controller name 'straight' is taken"),
                               ("stop", models.LGMDModel, "is not a subclass of "
                                "lgmd_sim.controllers.base.Controller")]:
        with pytest.raises(ValueError, match=message):
            controllers.register(name, cls)
    with pytest.raises(ValueError, match=r"controller 'lgmdplug\.drive:Nope'"):
        controllers.make("lgmdplug.drive:Nope")


def test_cell_keys_of_specs_are_file_names(plugin):
    [cell] = plan(["PassBy"], [0.5], ["lgmdplug.drive:Halt"], [])
    assert cell.key(3) == "PassBy-j0.5-lgmdplug.drive_Halt-s3"
    reactive = Cell("PassBy", 0.5, "reactive", "lgmdplug.looming:Mine", "fast+image")
    assert reactive.key(0) == "PassBy-j0.5-reactive-lgmdplug.looming_Mine-fast+image-s0"
    assert Cell("PassBy", 0.5, "reactive", "lgmd1", "published").key(0) == (
        "PassBy-j0.5-reactive-lgmd1-published-s0")  # the built-ins' stay as they were
