"""Environment wrappers: LGMD observations (single, Gymnasium vector, SB3 VecEnv), noise."""

from __future__ import annotations

import tracemalloc
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv

from lgmd_sim import models
from lgmd_sim.envs import JitterEnv
from lgmd_sim.envs.wrappers import (
    FrameObservation,
    LGMDObservation,
    LGMDVectorObservation,
    NoiseObservation,
)
from lgmd_sim.signals import noise

#: a model fed the IMU's rotation from info and one fitting it from the frames
STABILIZED = {"model": ["lgmd1", "feedback"], "preset": None, "history": 2, "grid": (1, 2),
              "stabilize": "imu", "gain": True}


SIZE = (32, 48)
NOISE = "gaussian:0.003,saltpepper:0.003"
#: several models, a short history and a 2 x 2 grid: every part of the observation
LGMD = {"model": ["feedback", "lgmd2"], "history": 3, "grid": (2, 2), "grid_history": 2,
        "memory": 3}


def make(time_limit: float = 0.2, scenario: str = "HandheldApproach", **kw) -> gym.Env:
    """A small, shaking environment; episodes of time_limit * 30 frames."""
    return JitterEnv(scenario, resolution=SIZE, time_limit=time_limit, **kw)


def noisy(time_limit: float) -> gym.Env:
    return NoiseObservation(make(time_limit), NOISE)


#: Environments ending after 6, 9 and 12 steps: streams restart at different times.
LIMITS = (0.2, 0.3, 0.4)


def cell_shares(s: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """The grid as documented, cell by cell: mean [S]+ per cell over the cells' sum."""
    r = np.linspace(0, s.shape[0], rows + 1).astype(int)
    c = np.linspace(0, s.shape[1], cols + 1).astype(int)
    means = np.array([np.maximum(s[r[i]:r[i + 1], c[j]:c[j + 1]], 0).mean(dtype=np.float64)
                      for i in range(rows) for j in range(cols)])
    return means / means.sum() if means.sum() > 0 else np.full(rows * cols, 1 / means.size)


def assert_same(a, b, path: str = "") -> None:
    """Equal, bit for bit, through dicts and object arrays (NaN equals NaN)."""
    if isinstance(a, dict):
        assert set(a) == set(b), f"{path}: keys {sorted(a)} != {sorted(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{path}[{k!r}]")
    elif isinstance(a, list | tuple) or (isinstance(a, np.ndarray) and a.dtype == object):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{path}[{i}]")
    elif a is None:
        assert b is None, path
    else:
        assert np.asarray(a).dtype == np.asarray(b).dtype, path
        np.testing.assert_array_equal(a, b, err_msg=path)


# --- one environment ----------------------------------------------------------------------


@pytest.mark.parametrize("name", ["feedback", "lgmd1"])  # LGMD1's S has negative values
def test_history_alarm_and_grid_follow_the_model_frame_by_frame(name):
    env = LGMDObservation(make(0.5), model=name, history=4, grid=(2, 3))
    reference = models.make(name)
    obs, info = env.reset(seed=1)
    assert set(obs) == {"frame", "proprio", "lgmd_potential", "lgmd_alarm", "lgmd_grid"}
    # a new stream: history at rest, no alarm, no S anywhere (uniform shares)
    assert obs["lgmd_potential"].tolist() == [0.5] * 4 and obs["lgmd_alarm"].tolist() == [0.0]
    np.testing.assert_array_equal(obs["lgmd_grid"], np.full(6, 1 / 6, np.float32))
    assert info["lgmd_potential"] == {name: 0.5} and info["lgmd_alarm"] == {name: False}
    reference.step(obs["frame"])
    previous = obs["lgmd_potential"]
    for _ in range(8):
        obs, _, _, _, info = env.step([0.0, 0.0])
        assert env.observation_space.contains(obs)
        out = reference.step(obs["frame"], layers=True)
        assert info["lgmd_potential"] == {name: out.potential}
        assert obs["lgmd_potential"][-1] == np.float32(out.potential)
        np.testing.assert_array_equal(obs["lgmd_potential"][:-1], previous[1:])  # shifted
        assert obs["lgmd_alarm"].tolist() == [float(out.alarm)]
        np.testing.assert_allclose(obs["lgmd_grid"], cell_shares(out.layers["S"], 2, 3),
                                   rtol=1e-6)
        previous = obs["lgmd_potential"]
    assert obs["lgmd_potential"].min() > 0.5 and obs["lgmd_grid"].std() > 0  # the shake
    obs, _ = env.reset(seed=1)  # new streams, history back at rest
    assert obs["lgmd_potential"].tolist() == [0.5] * 4
    env.close()


def test_a_grid_history_holds_the_last_grids_oldest_first_and_starts_at_the_first():
    env = LGMDObservation(make(0.5), model="lgmd1", grid=(2, 3), grid_history=3)
    present = LGMDObservation(make(0.5), model="lgmd1", grid=(2, 3))
    obs, _ = env.reset(seed=1)
    assert env.observation_space["lgmd_grid"].shape == (18,)
    np.testing.assert_array_equal(obs["lgmd_grid"], np.full(18, 1 / 6, np.float32))
    grids = [present.reset(seed=1)[0]["lgmd_grid"]] * 3  # a new stream: its first grid
    for _ in range(5):
        obs = env.step([0.0, 0.0])[0]
        grids = [*grids[1:], present.step([0.0, 0.0])[0]["lgmd_grid"]]
        np.testing.assert_array_equal(obs["lgmd_grid"], np.concatenate(grids))
    assert obs["lgmd_grid"][:6].tolist() != obs["lgmd_grid"][-6:].tolist()  # they move
    obs, _ = env.reset(seed=2)
    np.testing.assert_array_equal(obs["lgmd_grid"], np.full(18, 1 / 6, np.float32))
    env.close()
    present.close()


def test_the_memory_keeps_the_excitation_by_column_and_fades_over_its_frames():
    """Each frame, the column of the grid's largest share takes the potential's
    excitation (0 at rest, 1 at the threshold) where that is more; every column loses
    1 / memory a frame; a reset clears it."""
    env = LGMDObservation(make(1.0), model="lgmd1", grid=(2, 3), memory=4)
    threshold = env.features.models["lgmd1"].params.threshold
    obs, _ = env.reset(seed=3)
    assert env.observation_space["lgmd_memory"].shape == (3,)
    assert obs["lgmd_memory"].tolist() == [0.0] * 3
    expected, peak = np.zeros(3), 0.0
    for _ in range(25):
        obs = env.step([0.5, 0.0])[0]
        expected = np.maximum(expected - 1 / 4, 0.0)
        column = int(np.argmax(obs["lgmd_grid"])) % 3
        excitation = np.clip((obs["lgmd_potential"][-1] - 0.5) / (threshold - 0.5), 0, 1)
        expected[column] = max(expected[column], excitation)
        np.testing.assert_allclose(obs["lgmd_memory"], expected, atol=1e-6)
        peak = max(peak, float(excitation))
    assert peak > 0.5  # the approach excites it: the rule was checked on real values
    obs, _ = env.reset(seed=4)
    assert obs["lgmd_memory"].tolist() == [0.0] * 3
    env.close()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"memory": -1}, "memory must be an integer >= 0"),
    ({"memory": 1.5}, "memory must be an integer >= 0"),
    ({"memory": True}, "memory must be an integer >= 0"),
    ({"memory": 30, "grid": None}, "memory needs a grid"),
])
def test_a_bad_memory_is_refused_naming_it(kwargs, message):
    env = make()
    with pytest.raises(ValueError, match=message):
        LGMDObservation(env, **kwargs)
    env.close()


def test_several_models_are_concatenated_in_the_order_given_and_the_frame_can_go():
    both = LGMDObservation(make(), model=["lgmd1", "feedback"], history=2, grid=(1, 3),
                           keep_frame=False)
    alone = {n: LGMDObservation(make(), model=n, history=2, grid=(1, 3))
             for n in ("lgmd1", "feedback")}
    assert "frame" not in both.observation_space.spaces
    assert both.observation_space["lgmd_potential"].shape == (4,)
    assert both.observation_space["lgmd_grid"].shape == (6,)
    results = [both.reset(seed=2)] + [both.step([0.5, 0.0])[::4] for _ in range(5)]
    singles = {n: [e.reset(seed=2)] + [e.step([0.5, 0.0])[::4] for _ in range(5)]
               for n, e in alone.items()}
    for t, (obs, info) in enumerate(results):
        assert "frame" not in obs
        for k, name in enumerate(("lgmd1", "feedback")):
            one, one_info = singles[name][t]
            for key, size in (("lgmd_potential", 2), ("lgmd_alarm", 1), ("lgmd_grid", 3)):
                np.testing.assert_array_equal(obs[key][k * size:(k + 1) * size], one[key])
            assert info["lgmd_potential"][name] == one_info["lgmd_potential"][name]
    assert results[-1][1]["lgmd_potential"]["lgmd1"] != results[-1][1]["lgmd_potential"][
        "feedback"]
    for e in (both, *alone.values()):
        e.close()


@pytest.mark.parametrize("keep_frame", [True, False])
def test_gymnasium_and_sb3_checkers_pass(keep_frame):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    # 64 x 64: SB3's checker wants images of 36 x 36 or more
    env = LGMDObservation(NoiseObservation(JitterEnv("PassBy", resolution="small"), NOISE),
                          model=["feedback", "lgmd1"], keep_frame=keep_frame)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any other checker warning fails the test
        warnings.filterwarnings("ignore", message=".*different from the unwrapped version")
        check_env(env, skip_render_check=True)
        sb3_check_env(env, warn=True)
    env.close()


def test_without_grid_no_grid_key():
    env = LGMDObservation(make(), grid=None, history=1)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"frame", "proprio", "lgmd_potential", "lgmd_alarm"}
    assert obs["lgmd_potential"].shape == (1,)
    env.close()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"model": []}, "model must be"),
    ({"model": 3}, "model must be"),
    ({"model": ["feedback", "feedback"]}, "model names a model twice"),
    ({"model": "lgmd9"}, "unknown model 'lgmd9'"),
    ({"preset": "nope"}, "unknown preset 'nope'"),
    ({"mu": -1.0}, "mu"),
    ({"colour": 1}, "unknown parameter"),
    ({"history": 0}, "history must be"),
    ({"history": 2.5}, "history must be"),
    ({"grid": (0, 3)}, "grid must be"),
    ({"grid": (3,)}, "grid must be"),
    ({"keep_frame": "no"}, "keep_frame must be"),
])
def test_bad_arguments_raise_value_errors_naming_them(kwargs, message):
    env = make()
    with pytest.raises(ValueError, match=message):
        LGMDObservation(env, **kwargs)
    env.close()


def test_bad_environments_and_grids_are_refused():
    env = make()
    with pytest.raises(ValueError, match="env: needs a Dict observation space"):
        LGMDObservation(FrameObservation(env))
    with pytest.raises(ValueError, match="env: needs a Dict"):
        NoiseObservation(FrameObservation(env), NOISE)
    with pytest.raises(ValueError, match=r"lgmd_alarm.*already"):
        LGMDObservation(LGMDObservation(env))
    with pytest.raises(ValueError, match="grid 40x2 has more cells than the 32x48 frame"):
        LGMDObservation(env, grid=(40, 2)).reset(seed=0)
    env.close()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"history": 10**9}, "history=1000000000 is more than the 1048576 potentials"),
    ({"grid": (10000, 10000)}, "grid 10000x10000 has more cells than the 32x48 frame"),
    ({"grid": (32, 48), "grid_history": 10**6}, "grid 32x48 with grid_history=1000000 is"),
])
def test_sizes_beyond_the_frame_or_max_features_are_refused_before_anything_is_allocated(
        kwargs, message):
    env, envs = make(), SyncVectorEnv([make])
    tracemalloc.start()  # NumPy's arrays are traced too
    try:
        with pytest.raises(ValueError, match=message):
            LGMDObservation(env, **kwargs)
        with pytest.raises(ValueError, match=message):
            LGMDVectorObservation(envs, **kwargs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**20, peak
    env.close()
    envs.close()


def test_frame_observation():
    env = FrameObservation(make())
    obs, _ = env.reset(seed=0)
    assert isinstance(obs, np.ndarray) and obs.shape == (*SIZE, 3)
    assert env.observation_space.contains(obs)
    env.close()


# --- noise --------------------------------------------------------------------------------


def _frames(env: gym.Env, seeds: list[int | None], steps: int = 3) -> list[np.ndarray]:
    out = []
    for seed in seeds:
        out.append(env.reset(seed=seed)[0]["frame"])
        out += [env.step([0.0, 0.0])[0]["frame"] for _ in range(steps)]
    return out


def test_noise_is_seeded_by_the_reset_seed_and_frame_index():
    noises = noise.parse(NOISE)
    clean = _frames(make(1.0), [4])
    corrupted = _frames(NoiseObservation(make(1.0), NOISE), [4])
    for index, (c, n) in enumerate(zip(clean, corrupted, strict=True)):
        assert not np.array_equal(c, n)
        np.testing.assert_array_equal(n, noise.apply(c, noises, 4, index))
    # unseeded resets continue a generator seeded by the last seed: the episodes differ
    # and the run repeats; the wrapped environment's own episodes stay as they are
    env = NoiseObservation(make(1.0), noises)
    run = _frames(env, [4, None, None])
    assert all(np.array_equal(a, b) for a, b in zip(run[:4], corrupted, strict=True))
    own = _frames(make(1.0), [4, None, None])
    np.testing.assert_array_equal(run[4], noise.apply(own[4], noises, _second_seed(4), 0))
    assert not np.array_equal(run[4], run[8])
    again = _frames(env, [4, None, None])
    assert all(np.array_equal(a, b) for a, b in zip(run, again, strict=True))


def _second_seed(seed: int) -> int:
    """The episode seed of the first reset without a seed after reset(seed=seed)."""
    return int(np.random.default_rng(seed).integers(2**63))


def test_noise_keeps_grey_frames_and_reaches_the_lgmd():
    env = NoiseObservation(make(frame="grey"), "shake:2")
    obs, _ = env.reset(seed=0)
    assert obs["frame"].shape == (*SIZE, 1) and env.observation_space.contains(obs)
    # noise first, then the model sees the noisy frame
    seen = LGMDObservation(NoiseObservation(make(), "saltpepper:0.05"), history=1)
    clean = LGMDObservation(make(), history=1)
    reference = models.make("feedback")
    frames = _frames(NoiseObservation(make(), "saltpepper:0.05"), [0], steps=4)
    potentials = [reference.step(f).potential for f in frames]
    got = [seen.reset(seed=0)[1]] + [seen.step([0.0, 0.0])[4] for _ in range(4)]
    assert [i["lgmd_potential"]["feedback"] for i in got] == potentials
    without = [clean.reset(seed=0)[1]] + [clean.step([0.0, 0.0])[4] for _ in range(4)]
    assert [i["lgmd_potential"]["feedback"] for i in without][1:] != potentials[1:]


@pytest.mark.parametrize(("spec", "message"), [
    ("gauss:0.1", "unknown noise 'gauss'"),
    ("saltpepper:2", "level must be"),
    ([0.1], "noise must be"),
    (None, "noise must be"),
])
def test_bad_noise_raises(spec, message):
    env = make()
    with pytest.raises(ValueError, match=message):
        NoiseObservation(env, spec)
    env.close()


# --- vector environments ------------------------------------------------------------------


def _run_vector(envs, steps: int = 16) -> list[tuple]:
    results = [envs.reset(seed=5)]
    actions = np.zeros((envs.num_envs, 2), np.float32)
    results += [envs.step(actions) for _ in range(steps)]
    envs.close()
    return results


@pytest.mark.parametrize(("vector", "mode", "keep_frame"), [
    (SyncVectorEnv, AutoresetMode.NEXT_STEP, True),
    (AsyncVectorEnv, AutoresetMode.NEXT_STEP, False),
    (SyncVectorEnv, AutoresetMode.SAME_STEP, True),
])
def test_vector_wrapper_equals_separately_wrapped_envs(vector, mode, keep_frame):
    kw = {**LGMD, "keep_frame": keep_frame}
    separate = SyncVectorEnv([lambda t=t: LGMDObservation(noisy(t), **kw) for t in LIMITS],
                             autoreset_mode=mode)
    batched = LGMDVectorObservation(
        vector([lambda t=t: noisy(t) for t in LIMITS], autoreset_mode=mode), **kw)
    assert batched.single_observation_space == separate.single_observation_space
    assert batched.observation_space == separate.observation_space
    expected, got = _run_vector(separate), _run_vector(batched)
    assert_same(got, expected)
    # the test means something: episodes ended at different steps, the models moved
    ended = np.array([np.logical_or(r[2], r[3]) for r in expected[1:]])
    assert ended.sum(axis=0).tolist() == [2, 1, 1]
    potentials = np.array([r[0]["lgmd_potential"] for r in expected])
    assert (potentials > 0.5).mean() > 0.5
    if mode == AutoresetMode.SAME_STEP:
        assert any("final_obs" in r[-1] for r in expected[1:])


def test_vector_wrapper_refuses_partial_resets():
    with pytest.raises(ValueError, match="autoreset mode 'Disabled' is not supported"):
        LGMDVectorObservation(SyncVectorEnv([make], autoreset_mode=AutoresetMode.DISABLED))
    envs = LGMDVectorObservation(SyncVectorEnv([make, make]))
    with pytest.raises(ValueError, match="reset_mask"):
        envs.reset(options={"reset_mask": np.array([True, False])})
    envs.close()


@pytest.mark.slow
@pytest.mark.parametrize("vec_env", ["DummyVecEnv", "SubprocVecEnv"])
def test_sb3_wrapper_equals_dummy_vec_env_of_wrapped_envs(vec_env):
    from stable_baselines3.common import vec_env as sb3

    from lgmd_sim.envs.wrappers import VecLGMDObservation

    separate = sb3.DummyVecEnv([lambda t=t: LGMDObservation(noisy(t), **LGMD) for t in LIMITS])
    batched = VecLGMDObservation(
        getattr(sb3, vec_env)([lambda t=t: noisy(t) for t in LIMITS]), **LGMD)
    assert batched.observation_space == separate.observation_space

    def run(venv):
        venv.seed(5)
        results = [(venv.reset(), list(venv.reset_infos))]
        for _ in range(16):
            venv.step_async(np.zeros((3, 2), np.float32))
            obs, rewards, dones, infos = venv.step_wait()
            # float32 rewards: DummyVecEnv's buffer has them so, SubprocVecEnv's float64
            results.append((obs, rewards.astype(np.float32), dones, infos,
                            list(venv.reset_infos)))
        venv.close()
        return results

    expected, got = run(separate), run(batched)
    assert_same(got, expected)
    terminal = [info["terminal_observation"] for r in expected[1:] for info in r[3]
                if "terminal_observation" in info]
    assert len(terminal) == 4 and all("lgmd_potential" in t for t in terminal)


@pytest.mark.parametrize("mode", ["next", "same", "sb3"])
def test_wrappers_feed_the_rotation_from_info(mode):
    """Batched wrappers equal separately wrapped environments with an IMU-fed model."""
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    from lgmd_sim.envs.wrappers import LGMDObservation, LGMDVectorObservation

    if mode == "sb3":
        from stable_baselines3.common.vec_env import DummyVecEnv

        from lgmd_sim.envs.wrappers import VecLGMDObservation

        def run(venv):
            venv.seed(5)
            out = [venv.reset()]
            for _ in range(14):
                venv.step_async(np.zeros((3, 2), np.float32))
                obs, _rewards, dones, infos = venv.step_wait()
                out.append((obs, dones, [i.get("terminal_observation") for i in infos]))
            venv.close()
            return out

        separate = DummyVecEnv([lambda t=t: LGMDObservation(make(t), **STABILIZED)
                                for t in LIMITS])
        batched = VecLGMDObservation(DummyVecEnv([lambda t=t: make(t) for t in LIMITS]),
                                     **STABILIZED)
    else:
        auto = AutoresetMode.NEXT_STEP if mode == "next" else AutoresetMode.SAME_STEP

        def run(envs):
            out = [envs.reset(seed=5)[0]]
            for _ in range(14):
                obs, _r, _te, _tr, info = envs.step(np.zeros((3, 2), np.float32))
                out.append((obs, info.get("final_obs")))
            envs.close()
            return out

        separate = SyncVectorEnv([lambda t=t: LGMDObservation(make(t), **STABILIZED)
                                  for t in LIMITS], autoreset_mode=auto)
        batched = LGMDVectorObservation(SyncVectorEnv([lambda t=t: make(t) for t in LIMITS],
                                                      autoreset_mode=auto), **STABILIZED)
    assert batched.features.rotation_keys == ["imu_rotation"]
    assert_same(run(batched), run(separate))
