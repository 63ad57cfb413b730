"""The ecosystem's own expectations: GL backends that cannot load, Gymnasium's checkers and
specs on every wrapper, actions Gymnasium would refuse, stepping past the end, RecordVideo
and resizing the frame."""

from __future__ import annotations

import ctypes.util
import os
import subprocess
import sys
import textwrap
import warnings

import cv2
import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from lgmd_sim.envs import JitterEnv
from lgmd_sim.envs.wrappers import (
    FrameObservation,
    LGMDObservation,
    NoiseObservation,
    ResizeFrame,
)
from lgmd_sim.signals import noise

SIZE = [24, 32]


def run_cli(args: list[str], prelude: str = "", **env: str) -> subprocess.CompletedProcess:
    """`lgmd-sim ARGS` in a fresh interpreter (MuJoCo's backend is fixed per process),
    after `prelude` has run."""
    code = prelude + textwrap.dedent(f"""
        import sys
        from lgmd_sim.cli import main
        sys.exit(main({args!r}))
    """)
    # without the backend this process chose (lgmd_sim.world.gl sets both variables)
    inherited = {k: v for k, v in os.environ.items()
                 if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env={**inherited, **env})


# --- item 11: a GL backend whose library is missing ---------------------------------------

def hide(*names: str) -> str:
    """Code that makes every ctypes load of a library named like one of `names` fail, as on
    a system without it."""
    return textwrap.dedent(f"""
        import ctypes
        _init = ctypes.CDLL.__init__
        def _hidden(self, name, *args, **kwargs):
            if name is not None and any(n in str(name) for n in {names!r}):
                raise OSError(f"{{name}}: cannot open shared object file")
            _init(self, name, *args, **kwargs)
        ctypes.CDLL.__init__ = _hidden
    """)


RECORD = ["record", "PassBy", "{out}", "--resolution", "small", "--no-progress"]


def record(tmp_path, prelude: str = "", **env: str) -> subprocess.CompletedProcess:
    return run_cli([a.format(out=tmp_path / "r.avi") for a in RECORD], prelude, **env)


def assert_one_line_naming(result: subprocess.CompletedProcess, *words: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("lgmd-sim record: error: ")
    for word in words:
        assert word in lines[0], lines[0]


def test_egl_missing_is_one_line_naming_the_backend_and_packages(tmp_path):
    result = record(tmp_path, hide("EGL"), MUJOCO_GL="egl")
    assert_one_line_naming(result, "MUJOCO_GL=egl", "libEGL", "libegl1")
    assert not (tmp_path / "r.avi").exists()


@pytest.mark.skipif(ctypes.util.find_library("OSMesa") is not None,
                    reason="libOSMesa is installed here; the simulated case covers it")
def test_osmesa_missing_here_is_one_line_naming_the_package(tmp_path):
    assert_one_line_naming(record(tmp_path, MUJOCO_GL="osmesa"),
                           "MUJOCO_GL=osmesa", "libOSMesa", "libosmesa6")


def test_osmesa_missing_simulated(tmp_path):
    assert_one_line_naming(record(tmp_path, hide("OSMesa"), MUJOCO_GL="osmesa"),
                           "MUJOCO_GL=osmesa", "libOSMesa", "libosmesa6")


def test_no_backend_at_all_names_both_choices(tmp_path):
    result = record(tmp_path, hide("EGL", "OSMesa"), MUJOCO_GL="")
    assert_one_line_naming(result, "libEGL", "libOSMesa", "libegl1", "libosmesa6")


def test_pyopengl_platform_disagreeing_with_the_backend_is_one_line(tmp_path):
    result = record(tmp_path, MUJOCO_GL="egl", PYOPENGL_PLATFORM="osmesa")
    assert_one_line_naming(result, "PYOPENGL_PLATFORM=osmesa", "backend is egl (MUJOCO_GL)")


@pytest.mark.parametrize("value", ["egl1", "vulkan"])
def test_a_backend_mujoco_does_not_know_is_one_line_naming_the_valid_ones(tmp_path, value):
    # MuJoCo's own refusal is a RuntimeError 47 lines deep in its import
    result = record(tmp_path, MUJOCO_GL=value)
    assert_one_line_naming(result, f"MUJOCO_GL={value}", "egl", "osmesa", "glfw")
    assert not (tmp_path / "r.avi").exists()


def test_the_backend_is_read_as_mujoco_reads_it(monkeypatch):
    from lgmd_sim.world import gl

    monkeypatch.setenv("MUJOCO_GL", " OSMesa ")
    assert gl.choose_backend() == "osmesa"


# --- item 12: actions Gymnasium would refuse, stepping past the end -----------------------


@pytest.fixture
def env():
    e = JitterEnv("PassBy", resolution=SIZE, time_limit=0.1)
    yield e
    e.close()


@pytest.mark.parametrize("action", [np.array([0.5 + 0.1j, 0.0]), [0.5, 1j],
                                    np.array([0.5, 0.0], np.complex64)])
def test_complex_actions_are_refused_naming_the_action(env, action):
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)


@pytest.mark.parametrize("make", [
    lambda: JitterEnv("PassBy", resolution=SIZE, time_limit=0.1),
    lambda: gym.make("lgmd_sim/PassBy-v0", resolution=SIZE, time_limit=0.1),
    lambda: gym.make("lgmd_sim/PassBy-v0", resolution=SIZE, time_limit=0.1,
                     disable_env_checker=True).unwrapped,
], ids=["raw", "gym.make", "unwrapped"])
def test_stepping_past_the_end_needs_a_reset(make):
    env = make()
    try:
        env.reset(seed=0)
        done = False
        while not done:
            _, _, terminated, truncated, _ = env.step(np.zeros(2, np.float32))
            done = terminated or truncated
        with pytest.raises(gym.error.ResetNeeded):
            env.step(np.zeros(2, np.float32))
        env.reset(seed=1)
        env.step(np.zeros(2, np.float32))  # a reset makes it usable again
    finally:
        env.close()


# --- item 13: Gymnasium's checker and specs on every wrapper ------------------------------


def wrappers_of(env: gym.Env) -> list[tuple[type, dict]]:
    """The wrapper stack, outermost first: each wrapper's class and recorded arguments."""
    stack = []
    while isinstance(env, gym.Wrapper):
        stack.append((type(env), getattr(env, "_saved_kwargs", None)))
        env = env.env
    return stack


WRAPPED = {
    "noise": lambda e: NoiseObservation(e, "gaussian:0.005,shake:0.5"),
    "noise-objects": lambda e: NoiseObservation(e, noise.parse("saltpepper:0.01")),
    "frame": lambda e: FrameObservation(e),
    "lgmd": lambda e: LGMDObservation(e, model=["feedback", "lgmd2"], history=3, grid=(2, 2),
                                      keep_frame=False),
    "lgmd-params": lambda e: LGMDObservation(e, preset="paper", grid=None, threshold=0.8),
    "lgmd-of-noise": lambda e: LGMDObservation(NoiseObservation(e, "gaussian:0.003")),
    "frame-of-noise": lambda e: FrameObservation(NoiseObservation(e, "gaussian:0.003")),
    "resize": lambda e: ResizeFrame(e, (12, 16)),
    "resize-of-lgmd": lambda e: ResizeFrame(LGMDObservation(e, grid=None), (12, 16)),
}


def made(time_limit: float = 0.2) -> gym.Env:
    return gym.make("lgmd_sim/HandheldApproach-v0", resolution=SIZE, time_limit=time_limit)


@pytest.mark.parametrize("name", WRAPPED)
def test_every_wrapper_passes_gymnasiums_checker(name):
    env = WRAPPED[name](made())
    try:
        with warnings.catch_warnings():
            # check_env recommends the unwrapped env; the wrapper is what is checked here
            warnings.filterwarnings("ignore", message=".*different from the unwrapped")
            check_env(env)
    finally:
        env.close()


@pytest.mark.parametrize("name", WRAPPED)
def test_every_wrapper_round_trips_through_its_spec(name):
    env = WRAPPED[name](made())
    remade = gym.make(env.spec)
    try:
        assert wrappers_of(remade) == wrappers_of(env)
        assert remade.spec == env.spec
        a, _ = env.reset(seed=3)
        b, _ = remade.reset(seed=3)
        for _ in range(3):  # the same wrappers with the same arguments: the same stream
            action = np.array([0.7, 0.2], np.float32)
            a, *_ = env.step(action)
            b, *_ = remade.step(action)
        assert_same(a, b)
    finally:
        env.close()
        remade.close()


def assert_same(a, b) -> None:
    if isinstance(a, dict):
        assert set(a) == set(b)
        for k in a:
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    else:
        np.testing.assert_array_equal(a, b)


# --- item 16: RecordVideo, resizing the frame of the Dict observation ---------------------


def test_record_video_writes_the_episode(tmp_path):
    pytest.importorskip("moviepy", reason="RecordVideo needs moviepy (the 'video' extra)")
    env = gym.make("lgmd_sim/PassBy-v0", resolution=SIZE, time_limit=0.2,
                   render_mode="rgb_array")
    env = gym.wrappers.RecordVideo(LGMDObservation(env), str(tmp_path / "videos"),
                                   episode_trigger=lambda episode: True)
    env.reset(seed=0)
    steps, done = 0, False
    while not done:
        _, _, terminated, truncated, _ = env.step(np.zeros(2, np.float32))
        steps, done = steps + 1, terminated or truncated
    env.close()
    (video,) = (tmp_path / "videos").glob("*.mp4")
    capture = cv2.VideoCapture(str(video))
    frames = []
    while (frame := capture.read()[1]) is not None:
        frames.append(frame)
    # the reset frame and one per step; OpenCV may not decode moviepy's last frame
    assert steps <= len(frames) <= steps + 1 and frames[0].shape == (*SIZE, 3)


@pytest.mark.parametrize("frame", ["rgb", "grey"])
def test_resize_frame_resizes_the_frame_alone(frame):
    inner = gym.make("lgmd_sim/HandheldApproach-v0", resolution=[48, 64], time_limit=0.2,
                     frame=frame)
    env = ResizeFrame(LGMDObservation(inner), (12, 20))
    try:
        channels = 3 if frame == "rgb" else 1
        assert env.observation_space["frame"].shape == (12, 20, channels)
        assert env.observation_space["lgmd_potential"] == inner_space(env, "lgmd_potential")
        obs, _ = env.reset(seed=0)
        big, _ = env.env.reset(seed=0)
        assert obs["frame"].shape == (12, 20, channels) and obs["frame"].dtype == np.uint8
        expected = cv2.resize(big["frame"], (20, 12), interpolation=cv2.INTER_AREA)
        np.testing.assert_array_equal(obs["frame"], expected.reshape(12, 20, channels))
        np.testing.assert_array_equal(obs["lgmd_potential"], big["lgmd_potential"])
        assert env.observation_space.contains(env.step(np.zeros(2, np.float32))[0])
        check_env(gym.make(env.spec).unwrapped)
        assert wrappers_of(gym.make(env.spec)) == wrappers_of(env)
    finally:
        env.close()


def inner_space(env: gym.Env, key: str) -> gym.Space:
    return env.env.observation_space[key]


@pytest.mark.parametrize("shape", [(0, 10), (10,), (10.5, 10), "12x20", (10, 10, 3)])
def test_resize_frame_refuses_a_bad_shape(shape):
    with pytest.raises(ValueError, match="shape"):
        ResizeFrame(made(), shape)
