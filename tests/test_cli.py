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
    for command in ("detect", "record", "models", "envs", "demo", "speed"):
        assert command in out


def _subcommand_parsers(parser=None, path=()):
    """Every (sub)command's parser with its path, e.g. ("speed", "models")."""
    import argparse
    parser = parser or cli.build_parser()
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _subcommand_parsers(sub, (*path, name))


def test_every_option_has_help_stating_its_default():
    """A user reads the defaults in --help: every option explains itself, and one whose
    default is a value (not unset, off or empty) says what it is."""
    import argparse
    missing = []
    for path, parser in _subcommand_parsers():
        for a in parser._actions:
            if not a.option_strings or a.dest in ("help", "version"):
                continue
            meaningful = a.default not in (None, False, "", [], argparse.SUPPRESS)
            if not a.help or (meaningful and "default" not in a.help):
                missing.append(f"{' '.join(path)} {a.option_strings[0]}")
    assert missing == []


def test_help_texts_print_no_doubled_percent():
    """'%%' is argparse's escape in help strings only; in a description it prints as is."""
    doubled = [" ".join(path) for path, parser in _subcommand_parsers()
               if "%%" in parser.format_help()]
    assert doubled == []


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
        cli.main(["speed", "models", "--frames", "0"])
    assert exc.value.code == 2


def test_every_model_is_listed():
    assert models.available() == ["feedback", "lgmd1", "lgmd2", "f_on", "f_off"]


def test_a_missing_extra_is_a_one_line_error_naming_it(monkeypatch):
    from lgmd_sim.extras import MissingExtra, require

    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # as if not installed
    hint = (r"'rl' extra; install it from a checkout of lgmd-sim: "
            r"pip install -c constraints\.txt '\.\[rl\]'")
    with pytest.raises(MissingExtra, match=hint):
        require("stable_baselines3", "rl")
    assert require("numpy", "rl").__name__ == "numpy"


def test_record_refuses_a_bad_suffix_before_running(tmp_path, capsys):
    assert cli.main(["record", "PassBy", str(tmp_path / "clip.mov"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "clip.mov" in err and ".mkv" in err and not list(tmp_path.iterdir())


def test_record_writes_a_lossless_clip_with_its_collision_frame(tmp_path, capsys):
    from lgmd_sim.video import VideoReader

    out = tmp_path / "clip.mkv"
    assert cli.main(["record", "StationaryApproach", str(out), "--resolution", "small",
                     "--no-progress"]) == 0
    printed = capsys.readouterr().out
    frames = list(VideoReader(out))
    assert f"wrote {out}: {len(frames)} frames at 30 fps, collision at frame " in printed
    collision = int(printed.split("collision at frame ")[1].split()[0])
    assert collision == len(frames) - 1  # the episode ends at the collision
    assert f"lgmd-sim detect {out} --collision-frame {collision}" in printed


@pytest.mark.parametrize(("error", "shown"), [
    (OSError(28, "cannot write out/r.avi: No space left on device"),
     "cannot write out/r.avi: No space left on device"),
    (FileNotFoundError(2, "No such file or directory", "clip.mp4"),
     "clip.mp4: No such file or directory"),
    (OSError("cannot export to D: File exists"), "cannot export to D: File exists"),
])
def test_an_os_error_is_one_line_with_its_file_and_reason_and_no_errno(
        monkeypatch, capsys, error, shown):
    from lgmd_sim.cli import models as models_command

    def fail(args):
        raise error

    monkeypatch.setattr(models_command, "run", fail)
    assert cli.main(["models"]) == 2
    assert capsys.readouterr().err == f"lgmd-sim models: error: {shown}\n"


def test_a_run_records_the_pythonpath_its_plug_in_came_from(monkeypatch):
    from lgmd_sim.cli import command_line

    monkeypatch.delenv("PYTHONPATH", raising=False)
    assert command_line(["benchmark", "a b:C"]) == "lgmd-sim benchmark 'a b:C'"
    monkeypatch.setenv("PYTHONPATH", "my plugins")
    assert command_line(["benchmark", "eta_lgmd:EtaLGMD", "--calibrate"]) == \
        "PYTHONPATH='my plugins' lgmd-sim benchmark eta_lgmd:EtaLGMD --calibrate"
