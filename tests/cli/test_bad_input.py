"""Defects a hostile bad-input run found (issue 6), each kept fixed by a test.

1. a bad scenario file must not break the package;
2. detect's output names never collide;
3. a video's outputs are replaced as a set, and a failed input does not stop the others;
4. SIGTERM cleans partial files, and stale partials of a killed run are removed;
5. huge parameter values are refused with a ValueError naming the parameter;
6. small ones: full disk, early checks, stream indices, empty preset, step before reset,
   render after close, unknown reset options, a killed async worker.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest

import lgmd_sim
from lgmd_sim import cli, models
from lgmd_sim.envs.params import EnvParams
from lgmd_sim.signals import stimuli

ROOT = Path(__file__).resolve().parents[2]
SHAPE = (48, 64)


def _clip_frames(n: int) -> np.ndarray:
    return stimuli.approaching(SHAPE, start_distance=1.0, speed=2.0, still_frames=2,
                               look=stimuli.Look(background="texture")).frames[:n]


def _write_folder(folder: Path, frames: np.ndarray) -> Path:
    folder.mkdir(parents=True)
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:03d}.png"), f)
    return folder


def _detect(*args: str) -> int:
    return cli.main(["detect", *args, "--no-progress"])


# --- 1. one bad scenario file -------------------------------------------------------------

BAD_FILES = {
    "syntax": ("Broken.toml", b'description = "x"\n[params\njitter = 1\n', "Broken.toml"),
    "unknown key": ("Broken.toml", b'description = "x"\ncolour = "red"\n', "colour"),
    "params not a table": ("Broken.toml", b'description = "x"\nparams = 5\n', "params"),
    "not utf-8": ("Broken.toml", b'description = "caf\xe9"\n', "UTF-8"),
    "space in name": ("Bad Name.toml", b'description = "x"\n', "Bad Name.toml"),
}


def _copy_package(dest: Path) -> Path:
    """A copy of the checkout's package with its envs/ and assets/, to break one file."""
    ignore = shutil.ignore_patterns("__pycache__")
    for name in ("lgmd_sim", "envs", "assets"):
        shutil.copytree(ROOT / name, dest / name, ignore=ignore)
    return dest


@pytest.mark.parametrize("kind", list(BAD_FILES))
def test_a_bad_scenario_file_breaks_only_itself(tmp_path, kind):
    filename, content, mention = BAD_FILES[kind]
    root = _copy_package(tmp_path / "pkg")
    (root / "envs" / filename).write_bytes(content)
    code = textwrap.dedent("""
        import sys, gymnasium as gym
        import lgmd_sim
        from lgmd_sim import cli
        print("status", cli.main(["envs"]))
        env = gym.make("lgmd_sim/PassBy-v0", resolution="small"); env.close()
        print("PassBy ok")
        if "Broken" in sys.argv[1]:
            try:
                gym.make("lgmd_sim/Broken-v0")
            except ValueError as exc:
                print("make error:", exc)
    """)
    result = subprocess.run([sys.executable, "-c", code, filename], cwd=root,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    out, err = result.stdout, result.stderr
    assert "status 2" in out and "PassBy ok" in out
    assert "lgmd_sim/RoughTerrainObstacles-v0" in out  # the good ones are still listed
    errors = [line for line in err.splitlines() if filename in line]
    assert len(errors) == 1 and mention in errors[0], err
    if "Broken" in filename:
        (line,) = [x for x in out.splitlines() if x.startswith("make error:")]
        assert filename in line and mention in line


@pytest.fixture
def isolated_catalogue(monkeypatch):
    """Scenarios registered by a test are forgotten after it."""
    from gymnasium.envs import registration

    from lgmd_sim.envs import catalogue

    for name in ("_catalogue", "_unnamed", "_folders"):
        monkeypatch.setattr(catalogue, name, type(getattr(catalogue, name))(
            getattr(catalogue, name)))
    monkeypatch.setattr(registration, "registry", dict(registration.registry))
    monkeypatch.delenv("LGMD_SIM_ENVS", raising=False)


def test_a_user_catalogue_adds_scenarios(tmp_path, isolated_catalogue):
    from lgmd_sim.envs import register_catalogue

    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "TinyPassBy.toml").write_text(
        'description = "a near miss, small"\n[params]\nmover = "vehicle"\nmiss_distance = 1.0\n'
        'resolution = "small"\ncarrier = "tripod"\njitter = 0.0\n')
    assert register_catalogue(folder) == ["TinyPassBy"]
    env = gym.make("lgmd_sim/TinyPassBy-v0")
    assert env.observation_space["frame"].shape == (64, 64, 3)
    env.close()
    with pytest.raises(ValueError, match="no such folder"):
        register_catalogue(tmp_path / "missing")
    # register_catalogue set the environment variable: a fresh process loads it at import
    code = "import gymnasium as gym, lgmd_sim; print('lgmd_sim/TinyPassBy-v0' in gym.registry)"
    assert os.environ["LGMD_SIM_ENVS"] == str(folder.resolve())  # workers inherit it
    result = subprocess.run([sys.executable, "-c", code], capture_output=True,
                            text=True, check=True)
    assert result.stdout.strip() == "True"


def test_a_user_scenario_cannot_shadow_a_packaged_one(tmp_path, isolated_catalogue):
    from lgmd_sim.envs import register_catalogue
    from lgmd_sim.envs.catalogue import catalogue_errors

    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "PassBy.toml").write_text('description = "mine"\n')
    with pytest.warns(UserWarning, match="PassBy is already defined"):
        assert register_catalogue(folder) == []
    assert any("PassBy.toml" in e and "already" in e for e in catalogue_errors())


# --- 2. and 3. detect outputs -------------------------------------------------------------


@pytest.mark.slow
def test_detect_output_names_never_collide(tmp_path, capsys):
    # same stem, and an input really named like a numbered stem: three distinct result sets
    inputs = {"clip.avi": 6, "clip.mp4": 7, "clip-1": 8, "clip-2.mp4": 9}
    for name, n in inputs.items():
        _write_folder(tmp_path / "in" / name, _clip_frames(n))
    out = tmp_path / "out"
    assert _detect(*(str(tmp_path / "in" / n) for n in inputs), "--models", "lgmd1",
                   "--out", str(out)) == 0
    frames = {}
    for summary in out.glob("*.json"):
        record = json.loads(summary.read_text())
        frames[Path(record["video"]).name] = (summary.stem, record["frames"])
    assert {k: v[1] for k, v in frames.items()} == inputs
    assert len({v[0] for v in frames.values()}) == len(inputs)
    # predictable: unique stems stay stems, shared stems take their extension
    assert frames["clip-1"][0] == "clip-1" and frames["clip.avi"][0] == "clip.avi"


def test_outputs_are_replaced_as_a_set_and_other_inputs_still_run(tmp_path, capsys):
    a = _write_folder(tmp_path / "a", _clip_frames(6))
    b = _write_folder(tmp_path / "b", _clip_frames(7))
    out = tmp_path / "out"
    out.mkdir()
    for ext in ("json", "png"):
        (out / f"a.{ext}").write_text("previous run")
    (out / "a.csv").mkdir()  # the CSV cannot be moved into place
    assert _detect(str(a), str(b), "--models", "lgmd1", "--out", str(out)) == 2
    err = capsys.readouterr().err
    assert "a.csv" in err and len(err.strip().splitlines()) == 1
    for ext in ("json", "png"):  # untouched: a's set was not half-replaced
        assert (out / f"a.{ext}").read_text() == "previous run"
    assert json.loads((out / "b.json").read_text())["frames"] == 7  # b still ran
    assert not [p for p in out.iterdir() if "partial" in p.name]


# --- 4. SIGTERM and stale partials --------------------------------------------------------


def test_sigterm_while_writing_leaves_no_partial_files(tmp_path):
    clip = _write_folder(tmp_path / "clip", _clip_frames(6))
    out = tmp_path / "out"
    code = textwrap.dedent("""
        import os, signal, sys
        import lgmd_sim.detect.outputs as d
        write = d._write_figure
        def killed_while_writing(path, detection):
            os.kill(os.getpid(), signal.SIGTERM)
            write(path, detection)
        d._write_figure = killed_while_writing
        from lgmd_sim import cli
        sys.exit(cli.main(["detect", sys.argv[1], "--out", sys.argv[2], "--models", "lgmd1",
                           "--no-progress"]))
    """)
    result = subprocess.run([sys.executable, "-c", code, str(clip), str(out)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 128 + signal.SIGTERM, result.stderr
    assert "terminated" in result.stderr
    assert not out.exists()  # neither partials nor a half set, nor the folder made for them


def test_stale_partials_of_a_killed_run_are_removed(tmp_path, capsys):
    clip = _write_folder(tmp_path / "clip", _clip_frames(6))
    out = tmp_path / "out"
    out.mkdir()
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = out / f".clip.csv.{dead.pid}-x1y2.partial.csv"
    stale.write_text("half")
    alive = out / f".clip.csv.{os.getpid()}-x1y2.partial.csv"  # a live writer's: kept
    alive.write_text("in progress")
    assert _detect(str(clip), "--models", "lgmd1", "--out", str(out)) == 0
    assert not stale.exists() and alive.exists()


# --- 5. huge values -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("build", "name"),
    [
        (lambda: models.make("feedback", sigma1=1e12), "sigma1"),
        (lambda: models.make("feedback", sigma2=1e6), "sigma2"),
        (lambda: models.make("feedback", tv_window=10**9), "tv_window"),
        (lambda: models.make("feedback", delay_taps=10**9), "delay_taps"),
        (lambda: EnvParams(obstacle_kinds=[], n_obstacles=3), "obstacle_kinds"),
        (lambda: EnvParams(n_obstacles=2000), "n_obstacles"),
        (lambda: EnvParams(n_obstacles=1_000_000), "n_obstacles"),
        (lambda: EnvParams(scenery=1_000_000), "scenery"),
        (lambda: EnvParams(substeps=10_000_000), "substeps"),
        (lambda: EnvParams(multisample=10**6), "multisample"),
        (lambda: EnvParams(goal_distance=1e12), "goal_distance"),
        (lambda: EnvParams(obstacle_field=(2.0, 1e12, 2.5)), "obstacle_field"),
        (lambda: EnvParams(obstacle_ahead=1e12), "obstacle_ahead"),
    ],
)
def test_huge_values_are_refused_naming_the_parameter(build, name):
    with pytest.raises(ValueError, match=name):
        build()


def test_the_largest_allowed_world_builds():
    from lgmd_sim.world import JitterWorld
    from lgmd_sim.world.params import MAX_OBSTACLES, MAX_SCENERY

    p = EnvParams(n_obstacles=MAX_OBSTACLES, scenery=MAX_SCENERY,
                  obstacle_field=(2.0, 30.0, 15.0), resolution="small")
    world = JitterWorld(p)
    world.reset(seed=0)
    world.step(0.5, 0.0)
    world.close()


# --- 6. small ones ------------------------------------------------------------------------


def test_a_full_disk_names_the_file(tmp_path, monkeypatch, capsys):
    import lgmd_sim.detect.outputs as d

    def full(path, detection):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(d, "_write_csv", full)
    clip = _write_folder(tmp_path / "clip", _clip_frames(6))
    out = tmp_path / "out"
    assert _detect(str(clip), "--models", "lgmd1", "--out", str(out)) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "No space left on device" in err and str(out / "clip.csv") in err
    assert not out.exists()  # nor the folder made for the outputs


def test_bad_out_folder_and_collision_frame_are_checked_before_any_frame(
        tmp_path, monkeypatch, capsys):
    import lgmd_sim.detect.job as d

    def never(*args, **kwargs):
        raise AssertionError("frames were processed before the arguments were checked")

    monkeypatch.setattr(d, "detect", never)
    clip = _write_folder(tmp_path / "clip", _clip_frames(6))
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    assert _detect(str(clip), "--out", str(not_a_folder)) == 2
    assert str(not_a_folder) in capsys.readouterr().err
    assert _detect(str(clip), "--collision-frame", "6", "--out", str(tmp_path / "o")) == 2
    err = capsys.readouterr().err
    assert "collision frame 6" in err and "0..5" in err


def test_stream_indices_must_be_integers():
    batch = models.make("lgmd1", n_streams=2)
    batch.step(np.zeros((2, 8, 8), np.uint8))
    with pytest.raises(ValueError, match="integers"):
        batch.reset(streams=[0.7])
    with pytest.raises(ValueError, match="integers"):
        batch.reset(streams=[True])


def test_an_empty_preset_is_an_error():
    with pytest.raises(ValueError, match="unknown preset ''"):
        models.make("feedback", preset="")


def _unwrapped(**overrides):
    from lgmd_sim.envs import JitterEnv

    return JitterEnv("PassBy", resolution="small", **overrides)


def test_step_before_reset_render_after_close_and_unknown_options():
    env = _unwrapped(render_mode="rgb_array")
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        env.step([0.0, 0.0])
    with pytest.raises(ValueError, match="'speed'"):
        env.reset(seed=0, options={"speed": 2})
    env.reset(seed=0)
    assert env.render().shape == (64, 64, 3)
    env.close()
    with pytest.raises(gym.error.ClosedEnvironmentError, match="closed"):
        env.render()
    with pytest.raises(gym.error.ClosedEnvironmentError, match="closed"):
        env.step([0.0, 0.0])


def test_a_killed_async_worker_is_named():
    from lgmd_sim.envs.vector import make_async

    envs = make_async("lgmd_sim/PassBy-v0", 2, resolution="small")
    try:
        envs.reset(seed=0)
        victim = envs.processes[1]
        os.kill(victim.pid, signal.SIGKILL)
        victim.join(10)
        with pytest.raises(RuntimeError, match=r"worker 1 .*killed by signal 9"):
            envs.step(np.zeros((2, 2), np.float32))
    finally:
        envs.close(terminate=True)


def test_info_names_the_frame_index_and_reports_success():
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="small", goal_distance=1.5,
                   goal_radius=0.5, n_obstacles=0, jitter=0.0)
    _, info = env.reset(seed=0)
    assert "frame" not in info and info["frame_index"] == 0 and info["is_success"] is False
    for t in range(1, 200):
        _, _, terminated, truncated, info = env.step([1.0, 0.0])
        assert info["frame_index"] == t and info["is_success"] == info["goal_reached"]
        if terminated or truncated:
            break
    assert terminated and info["is_success"] is True
    env.close()


def test_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"lgmd-sim {lgmd_sim.__version__}"
    assert version("lgmd-sim") == lgmd_sim.__version__  # one version, in lgmd_sim/__init__.py


@pytest.mark.parametrize(("argv", "keys", "line"), [
    (["bench", "closed-loop", "--seeds", "0"], "",
     "argument --seeds: must be an integer >= 1, got 0"),
    (["bench", "closed-loop", "--jitter", "9"], "",
     "error: --jitter must hold jitter levels in [0, 5], got '9'"),
    (["train", "--envs", "0"], "", "error: --envs must be an integer >= 1, got 0"),
    (["bench", "closed-loop"], "cruise = 2\n",
     "error: {file}: cruise must be a number in [-1, 1], got 2"),
    (["bench", "open-loop"], "window = -1\n",
     "error: {file}: window must be a finite number >= 0, got -1"),
    (["calibrate", "--seeds", "200"], "heldout_seed = 150\n",
     "error: the search and held-out seeds overlap: move heldout_seed"),
    (["bench", "closed-loop", "--seeds", "3"], "seeds = 0\ncruise = 2\n",  # the option wins
     "error: {file}: cruise must be a number in [-1, 1], got 2"),
])
def test_the_command_line_names_the_option_where_the_config_names_the_field(
        argv, keys, line, tmp_path, capsys):
    """One check per field: the option's type and the configuration refuse a value with the
    same words; the command names its option where the configuration names its field, and
    its --config file where the file's key is at fault."""
    file = tmp_path / "keys.toml"
    file.write_text(keys)
    out = tmp_path / "never"
    try:
        code = cli.main([*argv, "--config", str(file), "--out", str(out)])
    except SystemExit as exc:  # argparse's own refusal, of the option's type
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert line.format(file=file) in err.strip().splitlines()[-1], err  # after any usage
    assert not out.exists()
