"""The MuJoCo jitter world: terrain, carriers, shake, SSIM, ground truth, determinism."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from lgmd_sim.signals import metrics
from lgmd_sim.world import JitterWorld, SceneParams, gl, terrain
from lgmd_sim.world.carriers import Shake
from lgmd_sim.world.render import SSIMStream

SMALL = "small"


def drive(world: JitterWorld, steps: int, v: float = 1.0, omega: float = 0.0) -> list[dict]:
    truths = []
    for _ in range(steps):
        world.step(v, omega)
        truths.append(world.truth)
    return truths


def isi(params: SceneParams, steps: int, seed: int = 0) -> float:
    world = JitterWorld(params, ssim=True)
    try:
        world.reset(seed=seed)
        return float(np.mean([t["ssim"] for t in drive(world, steps)]))
    finally:
        world.close()


# -- GL backend ---------------------------------------------------------------------------


def test_gl_backend_user_setting_wins(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert gl.choose_backend() == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    assert gl.choose_backend() in ("egl", "osmesa")


# -- terrain and shake --------------------------------------------------------------------


def test_terrain_flat_at_zero_roughness_and_seeded_otherwise():
    rng = np.random.default_rng
    assert not terrain.fractal_heights(rng(0), 41, 61, 0.1, 0.0, 0.5).any()
    a = terrain.fractal_heights(rng(1), 81, 121, 0.1, 0.01, 0.5)
    b = terrain.fractal_heights(rng(1), 81, 121, 0.1, 0.01, 0.5)
    c = terrain.fractal_heights(rng(2), 81, 121, 0.1, 0.01, 0.5)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert a.min() >= 0 and not a[0].any() and not a[:, -1].any()  # meets the plane
    inner = a[10:-10, 10:-10]
    assert 0.6 * 0.01 < inner.std() < 1.4 * 0.01


def test_terrain_scale_sets_bump_size():
    def roughness_of_slopes(scale: float) -> float:
        h = terrain.fractal_heights(np.random.default_rng(3), 101, 101, 0.1, 0.01, scale)
        return float(np.abs(np.diff(h[20:-20, 20:-20], axis=1)).mean())

    assert roughness_of_slopes(2.0) < 0.7 * roughness_of_slopes(0.2)


def test_shake_rms_and_band():
    fs, band = 240.0, (1.0, 6.0)
    shake = Shake(np.random.default_rng(0), math.radians(2.0), 0.01, band)
    t = np.arange(0, 60, 1 / fs)
    off = shake.at(t)
    assert off[:, :3].std(axis=0) == pytest.approx([math.radians(2.0)] * 3, rel=0.2)
    assert off[:, 3:].std(axis=0) == pytest.approx([0.01] * 3, rel=0.2)
    power = np.abs(np.fft.rfft(off[:, 0] * np.hanning(len(t)))) ** 2  # window: no leakage
    freq = np.fft.rfftfreq(len(t), 1 / fs)
    inside = power[(freq >= band[0] * 0.95) & (freq <= band[1] * 1.05)].sum()
    assert inside > 0.98 * power.sum()


# -- SSIM ---------------------------------------------------------------------------------


@pytest.mark.parametrize("shape", [(270, 480), (64, 64), (16, 20), (8, 9)])
def test_streaming_ssim_equals_metrics_ssim(shape):
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(3)]
    frames[1] = np.clip(frames[0].astype(int) + rng.integers(-30, 30, shape), 0, 255).astype(
        np.uint8)
    stream = SSIMStream(*shape)
    assert math.isnan(stream.push(frames[0]))
    values = []
    for prev, cur in itertools.pairwise(frames):
        values.append(stream.push(cur))
        assert values[-1] == pytest.approx(metrics.ssim(prev, cur), abs=1e-6)
    stream.reset()
    assert math.isnan(stream.push(frames[0]))
    assert [stream.push(cur) for cur in frames[1:]] == values  # the same bits again


def test_streaming_ssim_rejects_a_wrong_frame():
    stream = SSIMStream(16, 20)
    with pytest.raises(ValueError, match="SSIMStream"):
        stream.push(np.zeros((20, 16), np.uint8))
    with pytest.raises(ValueError, match="SSIMStream"):
        stream.push(np.zeros((16, 20), np.float32))


# -- carriers and physics -----------------------------------------------------------------


def test_robot_drives_and_turns_on_flat_ground():
    world = JitterWorld(SceneParams(carrier="robot", jitter=0.0, resolution=SMALL, scenery=0))
    world.reset(seed=0)
    truths = drive(world, 30, v=0.8)  # one second
    pos = truths[-1]["carrier_pos"]
    assert 0.6 < pos[0] < 0.85 and abs(pos[1]) < 0.02
    assert np.abs(truths[-1]["camera_angvel"]).max() < 0.05  # flat: no shake
    drive(world, 30, v=0.0, omega=1.0)
    q = world.truth["carrier_quat"]
    yaw = math.atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] ** 2 + q[3] ** 2))
    assert 0.7 < yaw < 1.1
    world.close()


def test_camera_is_rigid_on_the_robot_over_rough_ground():
    world = JitterWorld(SceneParams(carrier="robot", jitter=2.0, resolution=SMALL, scenery=0))
    world.reset(seed=1)
    offsets, rates = [], []
    for t in drive(world, 20):
        rot = np.empty(9)
        from lgmd_sim.world.gl import mujoco

        mujoco.mju_quat2Mat(rot, t["carrier_quat"])
        offsets.append(rot.reshape(3, 3).T @ (t["camera_pos"] - t["carrier_pos"]))
        rates.append(np.abs(t["camera_angvel"]).max())
    assert np.ptp(np.array(offsets), axis=0).max() < 1e-6  # bolted on: no gimbal
    assert max(rates) > 0.3  # and the bumps shake it
    world.close()


def test_tripod_ignores_commands_and_holds_still():
    world = JitterWorld(SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL), ssim=True)
    world.reset(seed=0)
    start = world.truth["camera_pos"].copy()
    frame0 = world.rgb.copy()
    truths = drive(world, 10, v=1.0, omega=1.0)
    assert np.allclose(truths[-1]["camera_pos"], start, atol=1e-6)
    assert np.array_equal(world.rgb, frame0) and truths[-1]["ssim"] == pytest.approx(1.0)


@pytest.mark.parametrize("carrier", ["robot", "handheld"])
def test_isi_falls_as_jitter_rises(carrier):
    values = [isi(SceneParams(carrier=carrier, jitter=j, resolution="rl", scenery=6), 24)
              for j in (0.0, 1.0, 2.0)]
    assert values[0] > values[1] > values[2], values
    assert values[0] > 0.85


def test_same_seed_gives_identical_frames_and_truth():
    params = SceneParams(carrier="robot", jitter=1.0, resolution=SMALL, n_obstacles=3,
                         mover="ball", scenery=4)
    runs = []
    for _ in range(2):
        world = JitterWorld(params)
        world.reset(seed=7)
        frames = [world.rgb.copy()]
        truths = [world.truth]
        for t in drive(world, 8, v=0.7, omega=0.3):
            frames.append(world.rgb.copy())
            truths.append(t)
        runs.append((frames, truths))
        world.close()
    (fa, ta), (fb, tb) = runs
    assert all(np.array_equal(a, b) for a, b in zip(fa, fb, strict=True))
    for a, b in zip(ta, tb, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            assert np.array_equal(a[key], b[key], equal_nan=True), key
    other = JitterWorld(params)
    other.reset(seed=8)
    assert not np.array_equal(other.rgb, fa[0])
    other.close()


# -- ground truth -------------------------------------------------------------------------


def test_balloon_at_tripod_collides_with_ground_truth_leading_up_to_it():
    world = JitterWorld(SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL,
                                    mover="balloon", mover_distance=4.0, mover_speed=2.0))
    world.reset(seed=3)
    truths = [world.truth]
    while not world.truth["collision"] and world.frame_index < 90:
        world.step(0.0, 0.0)
        truths.append(world.truth)
    hit = world.frame_index
    assert world.truth["collision"] and world.first_collision_frame == hit
    assert 50 < hit < 62  # about 4 m / 2 m/s minus the balloon's radius, at 30 fps
    early = truths[5]
    assert early["threat_closing_speed"] == pytest.approx(2.0, abs=0.1)
    assert abs(early["threat_bearing"]) < math.radians(20)
    # time to collision counts down to the frame of the collision
    assert early["threat_ttc"] == pytest.approx((hit - 5) / 30, abs=0.15)
    assert truths[-2]["threat_distance"] > 0 >= truths[-1]["threat_distance"] - 0.02
    world.step(0.0, 0.0)
    assert world.first_collision_frame == hit  # the first one stays


def test_robot_driving_into_obstacle_collides():
    world = JitterWorld(SceneParams(carrier="robot", jitter=0.0, resolution=SMALL,
                                    n_obstacles=1, obstacle_kinds=("wall",),
                                    obstacle_ahead=1.2, scenery=0))
    world.reset(seed=0)
    assert world.truth["threat_index"] == 0
    d0 = world.truth["threat_distance"]
    assert 0.5 < d0 < 1.2
    for _ in range(60):
        world.step(1.0, 0.0)
        if world.truth["collision"]:
            break
    assert world.truth["collision"] and world.first_collision_frame == world.frame_index
    assert world.truth["threat_distance"] < 0.01
    world.close()


def test_vehicle_passing_by_misses_at_the_set_distance():
    world = JitterWorld(SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL,
                                    mover="vehicle", mover_distance=12.0, mover_speed=8.0,
                                    miss_distance=1.0))
    world.reset(seed=2)
    truths = drive(world, 75, v=0.0)
    gaps = [t["threat_distance"] for t in truths]
    assert world.first_collision_frame == -1 and not any(t["collision"] for t in truths)
    assert 0.85 < min(gaps) < 1.15


def test_hand_held_camera_walks_into_hanging_balloon():
    world = JitterWorld(SceneParams(carrier="handheld", jitter=0.5, resolution=SMALL,
                                    n_obstacles=1, obstacle_kinds=("balloon",),
                                    obstacle_ahead=2.0, camera_height=1.3))
    world.reset(seed=4)
    drive(world, 75, v=1.0)
    assert 45 < world.first_collision_frame < 70


# -- parameters ---------------------------------------------------------------------------


@pytest.mark.parametrize("changes, match", [
    (dict(roughness=-0.01), "roughness"),
    (dict(resolution=(0, 64)), "resolution"),
    (dict(resolution=(100000, 64)), "resolution"),
    (dict(resolution="huge"), "resolution"),
    (dict(carrier="drone"), "carrier"),
    (dict(obstacle_kinds=("tree",)), "obstacle_kinds"),
    (dict(jitter=float("nan")), "jitter"),
    (dict(shake_band=(5.0, 2.0)), "shake_band"),
    (dict(arena=(200.0, 200.0), terrain_cell=0.05), "terrain tiles"),
])
def test_invalid_parameters_raise_clear_errors(changes, match):
    with pytest.raises(ValueError, match=match):
        SceneParams(**changes)


def test_jitter_scale_maps_to_roughness_and_shake():
    robot = SceneParams(carrier="robot", jitter=2.0)
    hand = SceneParams(carrier="handheld", jitter=2.0)
    assert robot.resolved_roughness == pytest.approx(2 * SceneParams(jitter=1.0).resolved_roughness)
    assert robot.resolved_shake == (0.0, 0.0) and hand.resolved_roughness == 0.0
    assert hand.resolved_shake[0] == pytest.approx(2 * SceneParams(
        carrier="handheld", jitter=1.0).resolved_shake[0])
    assert SceneParams(carrier="robot", jitter=2.0, roughness=0.0).resolved_roughness == 0.0
    assert SceneParams(jitter=0.0, carrier="tripod").resolved_shake == (0.0, 0.0)


def test_passing_shade_and_flicker_change_the_light():
    def brightness(**light) -> np.ndarray:
        world = JitterWorld(SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL,
                                        **light))
        world.reset(seed=0)
        values = [world.grey.mean()]
        for _ in range(240):  # 8 s: at least one passing shade
            world.step(0.0, 0.0)
            values.append(world.grey.mean())
        world.close()
        return np.array(values)

    steady = brightness()
    assert np.ptp(steady) == 0
    shaded = brightness(shade=0.8)
    assert shaded.min() < 0.85 * steady[0] and shaded.max() == pytest.approx(steady[0], abs=1)
    flicker = brightness(flicker=0.3, flicker_hz=6.0)
    assert np.abs(np.diff(flicker[:30])).mean() > 2  # changes frame to frame


@pytest.mark.parametrize("mover", ["ball", "swing"])
def test_thrown_ball_and_swinging_ball_hit_the_camera(mover):
    world = JitterWorld(SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL,
                                    mover=mover, mover_distance=2.0, mover_speed=2.0))
    world.reset(seed=5)
    drive(world, 60, v=0.0)
    assert 0 < world.first_collision_frame < 60


def test_shadows_and_multisampling_can_be_switched_on():
    frames = []
    for extra in ({}, {"shadows": True, "multisample": 4}):
        world = JitterWorld(SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL,
                                        n_obstacles=3, obstacle_field=(2.0, 4.0, 1.0),
                                        **extra))
        world.reset(seed=0)
        frames.append(world.rgb.copy())
        world.close()
    assert not np.array_equal(*frames)


@pytest.mark.parametrize("params", [
    SceneParams(carrier="robot", jitter=1.0, resolution=SMALL, n_obstacles=4,
                obstacle_ahead=3.0, scenery=0),
    SceneParams(carrier="tripod", jitter=0.0, resolution=SMALL, mover="ball",
                mover_distance=6.0, mover_speed=30.0),
], ids=["robot-among-obstacles", "fast-ball"])
def test_contacts_skipped_only_where_no_touch_can_be(params, monkeypatch):
    """`_may_touch` skips reading the contacts in frames where no carrier geom can reach a
    threat's: the collisions are those found reading them at every physics step."""
    def collisions(always: bool) -> tuple[list[bool], int]:
        world = JitterWorld(params)
        skipped = 0
        may_touch = world._may_touch

        def counted() -> bool:
            nonlocal skipped
            near = may_touch()
            skipped += not near
            return True if always else near

        monkeypatch.setattr(world, "_may_touch", counted)
        world.reset(seed=1)
        hits = [t["collision"] for t in drive(world, 90, v=1.0)]
        world.close()
        return hits, skipped

    (hits, skipped), (every, _) = collisions(False), collisions(True)
    assert any(hits) and hits == every
    assert skipped > 10  # the frames far from any threat read no contact


def test_ssim_is_in_the_truth_only_when_asked_and_changes_nothing_else():
    params = SceneParams(carrier="robot", jitter=1.0, resolution=SMALL, n_obstacles=2)
    truths = {}
    for asked in (False, True):
        world = JitterWorld(params, ssim=asked)
        world.reset(seed=4)
        truths[asked] = [world.truth, *drive(world, 5)]
        world.close()
    assert all("ssim" not in t for t in truths[False])
    assert math.isnan(truths[True][0]["ssim"]) and all(0 < t["ssim"] <= 1
                                                        for t in truths[True][1:])
    for plain, with_ssim in zip(truths[False], truths[True], strict=True):
        assert plain.keys() == with_ssim.keys() - {"ssim"}
        assert all(np.array_equal(plain[k], with_ssim[k]) for k in plain)
