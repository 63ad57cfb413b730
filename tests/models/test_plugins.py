"""A researcher's own models and controllers: by a "package.module:Class" spec, by
`register`, and by an installed distribution's entry point."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from lgmd_sim import controllers, models
from lgmd_sim.benchmark.episode import Cell, plan
from lgmd_sim.models.warp import Motion

# The plug-in, tests/plugins/lgmd_plug.py, by its specs.
SPEC = "lgmd_plug:Blink"
DRIVE = "lgmd_plug:Creep"
PLUGINS = Path(__file__).resolve().parents[1] / "plugins"


@pytest.fixture(autouse=True)
def plugin(fresh_registries, monkeypatch):
    """Each test starts from the built-ins (nothing registered, entry points read afresh),
    with tests/plugins on sys.path."""
    monkeypatch.syspath_prepend(str(PLUGINS))


def _looming(n: int = 6, size: tuple[int, int] = (24, 32)) -> np.ndarray:
    """A dark square growing on a textured background, uint8 (n, H, W)."""
    rng = np.random.default_rng(0)
    frames = np.repeat(rng.integers(100, 200, size, np.uint8)[None], n, axis=0)
    for t in range(n):
        r = 2 + 2 * t
        cy, cx = size[0] // 2, size[1] // 2
        frames[t, cy - r:cy + r, cx - r:cx + r] = 10
    return frames


def test_a_model_by_spec_with_a_preset_and_a_front_end():
    assert models.parse_spec(f"{SPEC}/fast+image") == (SPEC, "fast+image")
    assert models.parse_spec(SPEC) == (SPEC, "plain")
    name, preset = models.parse_spec(f"{SPEC}/fast+image")
    m = models.make(name, preset=preset)
    assert (m.params.scale, m.params.stabilize) == (200.0, "image")
    plain = models.make(SPEC, preset="plain+image")
    outs = [plain.step(f, layers=True) for f in _looming()]
    assert all(0.5 <= o.potential < 1.0 for o in outs) and outs[-1].potential > 0.5
    assert outs[-1].layers["P"].shape == (24, 32)
    batch = models.make(SPEC, preset="fast", n_streams=2)
    out = batch.step(np.stack([_looming()[1]] * 2))
    assert out.potential.shape == (2,)
    assert list(models.presets_of(SPEC)) == ["plain", "fast"]


@pytest.mark.parametrize(("spec", "message"), [
    ("lgmd_plug_absent.looming:Blink", "cannot import module 'lgmd_plug_absent.looming'"),
    ("lgmd_plug:Nope", "module 'lgmd_plug' has no 'Nope'"),
    ("lgmd_plug:BlinkParams", "is not a subclass of lgmd_sim.models.base.LGMDModel"),
    ("lgmd_plug:np", "is not a subclass"),
    ("blink", "unknown model 'blink'; available: feedback"),
])
def test_a_bad_spec_is_a_one_line_error_naming_it(spec, message):
    with pytest.raises(ValueError, match=message) as exc:
        models.parse_spec(f"{spec}/fast")
    assert len(str(exc.value).splitlines()) == 1 and spec in str(exc.value)


def test_a_plug_in_module_not_found_says_to_put_its_folder_on_pythonpath():
    with pytest.raises(ValueError) as exc:
        models.model_class("lgmd_nowhere:Mine")
    assert str(exc.value) == (
        "model 'lgmd_nowhere:Mine': cannot import module 'lgmd_nowhere' (No module named "
        "'lgmd_nowhere'): put the folder that holds lgmd_nowhere.py or lgmd_nowhere/ on "
        "PYTHONPATH (as PYTHONPATH=examples does for examples/eta_lgmd.py)")


@pytest.mark.parametrize("name", [f"{SPEC}/fast", f"{SPEC}+image", "lgmd_plug.:Blink",
                                  "lgmd_plug:Blink.x", "lgmd-plug:Blink"])
def test_a_spec_with_more_than_a_module_and_a_class_is_an_unknown_model(name):
    with pytest.raises(ValueError, match=re.escape(f"unknown model {name!r}; available: ")):
        models.model_class(name)


def test_a_model_without_state_maps_runs_without_front_ends_only():
    for preset in ("plain+image", "plain+gain"):
        with pytest.raises(ValueError) as exc:
            models.make("lgmd_plug:NoMaps", preset=preset)
        assert str(exc.value) == ("nomaps lists no state maps (state_maps), so it runs "
                                  "without front ends only: stabilize 'none', gain off")
    m = models.make("lgmd_plug:NoMaps")
    frames = _looming()
    m.step(frames[0])
    with pytest.raises(ValueError) as exc:
        m.step(frames[1], motion=Motion(np.eye(3)))
    assert str(exc.value) == "nomaps lists no state maps (state_maps), so it takes no motion="
    assert m.step(frames[1]).potential > 0.5


def test_register_by_class_and_by_string():
    from lgmd_plug import Blink

    models.register("mine", Blink)
    models.register("mine_later", SPEC)  # imported on first use
    assert models.available()[-2:] == ["mine", "mine_later"]
    assert models.origin("mine") == "registered"
    assert models.model_class("mine_later") is Blink
    assert models.parse_spec("mine_later/fast+gain") == ("mine_later", "fast+gain")
    assert models.make("mine", preset="fast").params.scale == 200.0


@pytest.mark.parametrize(("name", "cls", "message"), [
    ("feedback", SPEC, "model name 'feedback' is taken \\(built-in\\)"),
    ("mine", dict, "model 'mine': class builtins.dict is not a subclass"),
    ("my:mine", SPEC, "a model name is a non-empty string without"),
    ("mine/fast", SPEC, "a model name is a non-empty string without"),
    ("mine", "lgmd_plug.Blink", "is not a 'package.module:Class' string"),
    ("mine", f"{SPEC}/fast", "is not a 'package.module:Class' string"),
])
def test_register_refuses(name, cls, message):
    before = models.available()
    with pytest.raises(ValueError, match=message):
        models.register(name, cls)
    assert models.available() == before
    assert models.origin(name) == ("built-in" if name == "feedback" else "spec")


def test_a_name_is_taken_once():
    models.register("mine", SPEC)
    with pytest.raises(ValueError, match="'mine' is taken \\(registered\\)"):
        models.register("mine", SPEC)


def test_an_entry_point_named_like_a_built_in_or_with_a_separator_is_skipped(distribution):
    distribution("".join(f"{name} = {SPEC}\n" for name in (
        "lgmd1", "my/mine", "my+mine", "myplug_mine")))
    with pytest.warns(UserWarning) as caught:
        assert models.available()[5:] == ["myplug_mine"]
    assert [str(w.message) for w in caught] == [
        "model entry point 'lgmd1' of myplug skipped: the name is taken",
        "model entry point 'my/mine' of myplug skipped: the name holds one of ':/+, '",
        "model entry point 'my+mine' of myplug skipped: the name holds one of ':/+, '"]
    assert models.model_class("lgmd1").__module__ == "lgmd_sim.models.lgmd1"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        models.available()  # read once: no warning again


def test_a_controller_by_spec_and_by_name():
    from lgmd_plug import Creep

    assert isinstance(controllers.make(DRIVE), Creep)
    controllers.register("creep", Creep)
    assert controllers.available()[-1] == "creep"
    assert controllers.controller_class("creep") is Creep
    for name, cls, message in [("straight", Creep, "controller name 'straight' is taken"),
                               ("stop", models.LGMDModel, "is not a subclass of "
                                "lgmd_sim.controllers.base.Controller")]:
        with pytest.raises(ValueError, match=message):
            controllers.register(name, cls)
    with pytest.raises(ValueError, match=r"controller 'lgmd_plug:Nope'"):
        controllers.make("lgmd_plug:Nope")


def test_cell_keys_of_specs_are_file_names():
    [cell] = plan(["PassBy"], [0.5], [DRIVE], [])
    assert cell.key(3) == "PassBy-j0.5-lgmd_plug_Creep-s3"
    reactive = Cell("PassBy", 0.5, "reactive", SPEC, "fast+image")
    assert reactive.key(0) == "PassBy-j0.5-reactive-lgmd_plug_Blink-fast+image-s0"
    assert Cell("PassBy", 0.5, "reactive", "lgmd1", "published").key(0) == (
        "PassBy-j0.5-reactive-lgmd1-published-s0")  # the built-ins' stay as they were
