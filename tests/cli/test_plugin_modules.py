"""Plug-in models in the commands: a module that fails at import is one line in every
command, and an installed distribution's models are listed by `lgmd-sim models`."""

import pytest

from lgmd_sim import cli, models

# each test from the built-ins (nothing registered, entry points read afresh), with the
# test plug-ins (tests/plugins/lgmd_plug.py) on sys.path
pytestmark = pytest.mark.usefixtures("fresh_registries", "test_plugins_on_path")
SPEC = "lgmd_plug:Blink"


@pytest.mark.parametrize(("code", "message"), [
    ("def broken(:\n", "importing it raised SyntaxError: invalid syntax ({module}.py, line 1)"),
    ("raise RuntimeError('no GPU')\n",
     "importing it raised RuntimeError: no GPU ({module}.py, line 1)"),
    ("import sys\nsys.exit(3)\n", "importing it called sys.exit(3) ({module}.py, line 2)"),
])
@pytest.mark.parametrize("command", ["detect", "benchmark"])
def test_a_plug_in_module_that_fails_at_import_is_one_line_in_every_command(
        tmp_path, monkeypatch, capsys, approach, code, message, command):
    """Not only ImportError: whatever the module raises (or exits with) at import is the
    user's to fix, said in one line as `models --check` says it, with no folder made."""
    module = f"lgmd_broken_{command}"
    (tmp_path / f"{module}.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))
    out, spec = tmp_path / "out", f"{module}:Mine"
    args = ([str(approach[0]), "--models", spec] if command == "detect"
            else [spec, "--workers", "1"])
    assert cli.main([command, *args, "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"cannot import module {module!r}: " in err
    assert err.endswith(message.format(module=module) + (")" if command == "benchmark"
                                                          else ""))
    assert not out.exists()


def test_an_installed_distributions_models_are_listed(distribution, capsys):
    distribution(f"myplug_mine = {SPEC}\n")

    assert models.available() == ["feedback", "lgmd1", "lgmd2", "f_on", "f_off",
                                  "myplug_mine"]
    assert models.origin("myplug_mine") == "entry point of myplug"
    assert models.make("myplug_mine", preset="fast+image").params.stabilize == "image"
    with pytest.raises(ValueError, match="taken \\(entry point of myplug\\)"):
        models.register("myplug_mine", SPEC)
    assert cli.main(["models"]) == 0
    out = capsys.readouterr().out
    assert ("myplug_mine: A test detector: the potential rises with the mean frame change. "
            "(entry point of myplug)") in out
    assert "presets: plain, fast (default plain)" in out and "scale = 20.0  [test]" in out
