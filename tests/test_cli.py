"""The `lgmd-sim` entry point: subcommands, help, and one-line errors with exit code 2."""

import subprocess
import sys

import pytest

from lgmd_sim import cli, models


def test_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for command in ("detect", "models", "envs", "demo", "bench"):
        assert command in out


def test_help_does_not_import_mujoco():
    # `lgmd-sim --help` and `lgmd-sim detect` must stay light: MuJoCo loads only for the world.
    code = ("import sys; from lgmd_sim import cli; cli.build_parser();"
            "print('mujoco' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip() == "False"


def test_models_lists_parameters_with_sources(capsys):
    assert cli.main(["models", "feedback"]) == 0
    out = capsys.readouterr().out
    assert "beta1" in out and "Table 1" in out


def test_unknown_model_is_a_one_line_error(capsys):
    assert cli.main(["models", "lgmd9"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "lgmd9" in err and "feedback" in err


def test_bad_argument_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["bench", "models", "--frames", "0"])
    assert exc.value.code == 2


def test_every_model_is_listed():
    assert models.available() == ["feedback", "lgmd1", "lgmd2", "f_on", "f_off"]
