"""The `lgmd-sim` entry point: subcommands, help, and one-line errors with exit code 2."""

import subprocess
import sys

import pytest

from lgmd_sim import cli, models


def test_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()
              if line.startswith("    ") and not line.startswith("     ")]
    assert listed == list(cli.COMMANDS)
    # the maintainers' tools are scripts of the checkout, not the user's commands
    assert "speed" not in listed and "reference" not in listed


def _subcommand_parsers(parser=None, path=()):
    """Every (sub)command's parser with its path, e.g. ("bench", "closed-loop")."""
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


def test_every_model_is_listed():
    assert models.available() == ["feedback", "lgmd1", "lgmd2", "f_on", "f_off"]


def test_a_missing_extra_is_a_one_line_error_naming_it(monkeypatch):
    from lgmd_sim.core.extras import MissingExtra, require

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
    from lgmd_sim.signals.video import VideoReader

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


#: Every command's options: those --help lists first, then (after "|") those it lists under
#: "advanced". A refactor of the command line keeps these; a new option joins one side.
OPTIONS = {
    "": "--version",
    "demo": "--out --seed --jitter --models --no-avoid"
            " | --resolution --avoider --avoid-seed --avoid-resolution",
    "detect": "--models --preset --collision-frame --out --json --no-progress"
              " | --window --noise --noise-seed --stabilize --fov",
    "record": "--seed --jitter --resolution --cruise --no-progress",
    "models": "--check",
    "envs": "",
    "bench": "",
    "bench closed-loop": "--scenarios --controllers --models --presets --policies --jitter"
                         " --seeds --config --out --resume --workers --no-progress"
                         " | --first-seed --resolution",
    "bench open-loop": "--scenarios --jitter --models --presets --seeds --dataset --config --out"
                       " --resume --workers --no-progress"
                       " | --first-seed --resolution",
    "calibrate": "--task --detectors --budget --seeds --save-presets --config --out --resume"
                 " --workers --no-progress"
                 " | --first-seed --resolution",
    "dataset": "",
    "dataset generate": "--scenarios --jitter --episodes --out --resolution --workers"
                        " --no-progress"
                        " | --controller --models --noise --video --seed --set",
    "dataset verify": "",
    "dataset export": "--format --codec",
    "train": "--algo --env --obs --model --preset --steps --envs --seed --config --out --resume"
             " --no-progress"
             " | --resolution --jitter --hp",
    "benchmark": "--out --smoke --calibrate --workers --no-progress | --protocol",
    "leaderboard": "--out --protocol",
    "verify": "--episodes --all --workers --no-progress | --protocol --seed",
}


def test_every_command_lists_the_options_a_user_needs_first_and_the_rest_as_advanced():
    """The command line's options, none lost: each command's first ones, then the research
    and tuning ones under the heading "advanced" in its --help."""
    found = {}
    for path, parser in _subcommand_parsers():
        more = [g for g in parser._action_groups if g.title == "advanced"]
        late = {id(a) for g in more for a in g._group_actions}
        sides = ([], [])
        for a in parser._actions:
            if a.option_strings and a.dest != "help":
                sides[id(a) in late].extend(a.option_strings)
        found[" ".join(path)] = (set(sides[0]), set(sides[1]))
        assert len(more) == (1 if sides[1] else 0)
        assert ("\nadvanced:\n" in parser.format_help()) == bool(sides[1])
    assert found == {command: tuple(set(side.split()) for side in text.partition(" | ")[::2])
                     for command, text in OPTIONS.items()}


#: Command lines of the docs (docs/guides/training.md's recipe; the others with fewer models
#: or policies) and what they parse to: where --help lists an option changes nothing.
PARSED = {
    "train --obs features --model feedback --preset robot-image --config student.toml "
    "--steps 104000 --out runs/mine": {
        "command": "train", "algo": None, "env": None, "obs": "features", "model": "feedback",
        "preset": "robot-image", "steps": 104000, "envs": None, "seed": None,
        "config": "student.toml", "out": "runs/mine", "resume": None, "no_progress": False,
        "resolution": None, "jitter": None, "hp": None},
    "bench closed-loop --policies runs/mine,runs/mine/best --controllers none --first-seed 900 "
    "--seeds 50 --out runs/choice --no-progress": {
        "command": "bench", "what": "closed-loop", "scenarios": None, "controllers": "none",
        "models": None, "presets": None, "policies": ("runs/mine", "runs/mine/best"),
        "jitter": None, "seeds": 50, "config": None, "out": "runs/choice", "resume": False,
        "workers": None, "no_progress": True, "first_seed": 900, "resolution": None},
    "bench closed-loop --scenarios RoughTerrainObstacles,ArenaRoam --jitter 1 "
    "--models lgmd2/robot-imu,lgmd1/robot-image --config sides.toml "
    "--out runs/closed-loop-robot-j1 --workers 2 --no-progress": {
        "command": "bench", "what": "closed-loop",
        "scenarios": ("RoughTerrainObstacles", "ArenaRoam"), "controllers": None,
        "models": "lgmd2/robot-imu,lgmd1/robot-image", "presets": None, "policies": None,
        "jitter": "1", "seeds": None, "config": "sides.toml",
        "out": "runs/closed-loop-robot-j1", "resume": False, "workers": 2, "no_progress": True,
        "first_seed": None, "resolution": None},
    "bench open-loop --jitter 0,1 --config no-noise.toml --first-seed 200 "
    "--models feedback/paper+image,lgmd1/calibrated-image --out runs/open-loop-compensated "
    "--workers 2 --no-progress": {
        "command": "bench", "what": "open-loop", "scenarios": None, "jitter": "0,1",
        "models": "feedback/paper+image,lgmd1/calibrated-image", "presets": None, "seeds": None,
        "dataset": None, "config": "no-noise.toml", "out": "runs/open-loop-compensated",
        "resume": False, "workers": 2, "no_progress": True, "first_seed": 200,
        "resolution": None},
    "calibrate --task robot --budget 16 --seeds 6 --save-presets "
    "--detectors eta_lgmd:EtaLGMD+imu --out runs/calibration-eta --workers 2 --no-progress "
    "--resume": {
        "command": "calibrate", "task": "robot", "detectors": ("eta_lgmd:EtaLGMD+imu",),
        "budget": 16, "seeds": 6, "save_presets": True, "config": None,
        "out": "runs/calibration-eta", "resume": True, "workers": 2, "no_progress": True,
        "first_seed": None, "resolution": None},
    "dataset generate --scenarios PassBy --jitter 0,1 --episodes 2 --resolution small "
    "--workers ray --out ray-dataset": {
        "command": "dataset", "what": "generate", "scenarios": ("PassBy",), "jitter": "0,1",
        "episodes": 2, "out": "ray-dataset", "resolution": "small", "controller": None,
        "models": None, "noise": None, "video": None, "seed": None, "set": [],
        "workers": "ray", "no_progress": False},
    "detect handheld.mp4 --collision-frame 96 --stabilize image --fov 55 "
    "--out docs/stabilize/image": {
        "command": "detect", "videos": ["handheld.mp4"], "models": None, "preset": None,
        "collision_frame": 96, "out": "docs/stabilize/image", "json": False,
        "no_progress": False, "window": None, "noise": None, "noise_seed": None,
        "stabilize": "image", "fov": 55.0},
}


@pytest.mark.parametrize("line", PARSED, ids=lambda line: line[:30])
def test_a_documented_command_line_parses_to_the_same_arguments(line):
    import shlex

    assert vars(cli.build_parser().parse_args(shlex.split(line))) == PARSED[line]
