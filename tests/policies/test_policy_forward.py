"""A policy's action computed in an order of lgmd-sim's own (`lgmd_sim.policies.forward`), so
that its episodes replay on any processor: the same action as stable-baselines3's
``predict`` to float32 roundoff, the same bits on every call and wherever its arrays lie,
and a pixel policy's CNN left to ``predict``. The golden fingerprint of the shipped policy's
episode is in tests/benchmark/test_replay.py."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import controllers, policies
from lgmd_sim.policies import forward
from lgmd_sim.policies.observe import base_env

#: How far from torch's action: float32 roundoff through a few layers (measured: 1e-6 at most).
CLOSE = 1e-5


@pytest.fixture(scope="module")
def shipped():
    return policies.load("shipped")


def _observations(policy, n: int) -> list[dict[str, np.ndarray]]:
    """`n` observations drawn from `policy`'s observation space, normalised as it is."""
    space = policy.network.observation_space
    space.seed(0)
    return [policy.normalize(space.sample()) for _ in range(n)]


def _worst(fwd, network, observations) -> float:
    """The largest |difference| between `fwd`'s actions and ``predict``'s."""
    worst = 0.0
    for obs in observations:
        ours, (theirs, _) = fwd(obs), network.predict(obs, deterministic=True)
        assert ours.dtype == np.float32 and ours.shape == theirs.shape
        worst = max(worst, float(np.abs(ours - theirs).max()))
    return worst


def test_the_shipped_policy_acts_as_torch_does_to_float32_roundoff(shipped):
    fwd = forward.build(shipped.network)
    assert fwd is not None and fwd.keys == tuple(shipped.network.observation_space.spaces)
    assert _worst(fwd, shipped.network, _observations(shipped, 300)) < CLOSE


def _sac(space: gym.spaces.Dict, action_space: gym.spaces.Box, **kwargs):
    from stable_baselines3 import SAC

    network = SAC.policy_aliases["MultiInputPolicy"](space, action_space, lambda _: 0.0,
                                                     net_arch=[16, 16], **kwargs)
    network.set_training_mode(False)
    return network


@pytest.mark.parametrize("use_sde", [False, True])  # gSDE: the mean through Hardtanh
def test_a_sac_policy_acts_as_torch_does_its_action_squashed_into_the_bounds(use_sde):
    space = gym.spaces.Dict({"b": gym.spaces.Box(-5, 5, (3, 2), np.float32),
                             "a": gym.spaces.Box(-5, 5, (4,), np.float64)})
    # bounds other than [-1, 1]: the rescaling is computed, not the identity
    action_space = gym.spaces.Box(np.array([-1, 0], np.float32), np.array([2, 0.5], np.float32))
    network = _sac(space, action_space, use_sde=use_sde)
    fwd = forward.build(network)
    assert fwd is not None and fwd.squash
    space.seed(0)
    assert _worst(fwd, network, [space.sample() for _ in range(100)]) < CLOSE


def _elsewhere(a: np.ndarray) -> np.ndarray:
    """A copy of float32 `a` at another address, 4 bytes off `a`'s alignment: a vectorised
    loop would take another path there (its alias and alignment checks)."""
    block = np.empty(a.size + 1, np.float32)
    copy = block[1:].reshape(a.shape)
    copy[...] = a
    return copy


def test_the_forward_gives_the_same_bits_every_call_and_wherever_its_arrays_lie(shipped):
    fwd = forward.build(shipped.network)
    obs = _observations(shipped, 1)[0]
    first = fwd(obs)
    assert fwd(obs).tobytes() == first.tobytes()
    assert forward.build(shipped.network)(obs).tobytes() == first.tobytes()
    layer = fwd.layers[0]
    x = fwd.features(obs)
    expected = layer(x)
    out = _elsewhere(np.zeros_like(expected))
    forward.dense(_elsewhere(layer.weight), _elsewhere(layer.bias), _elsewhere(x), out)
    assert out.tobytes() == expected.tobytes()
    # and the order is the one written: Python's floats (IEEE doubles, no fused
    # multiply-add) added in that order give the same bits
    for i in range(layer.weight.shape[0]):
        acc = float(layer.bias[i])
        for j in range(layer.weight.shape[1]):
            acc += float(layer.weight[i, j]) * float(x[j])
        assert np.float32(acc) == expected[i]


def test_an_observation_of_another_size_is_refused_before_the_kernel_reads_it(shipped):
    fwd = forward.build(shipped.network)
    obs = dict(_observations(shipped, 1)[0])
    obs["goal"] = obs["goal"][:-1]
    with pytest.raises(ValueError, match="the network takes 83 features"):
        fwd(obs)


def test_a_policy_with_a_cnn_keeps_torch():
    from stable_baselines3 import PPO

    frames = gym.spaces.Box(0, 255, (4, 36, 48), np.uint8)  # stacked grey frames, as pixels'
    action_space = gym.spaces.Box(-1, 1, (2,), np.float32)
    space = gym.spaces.Dict({"frame": frames, "proprio": gym.spaces.Box(-1, 1, (3,), np.float32)})
    for alias, observed in (("MultiInputPolicy", space), ("CnnPolicy", frames)):
        network = PPO.policy_aliases[alias](observed, action_space, lambda _: 0.0)
        assert forward.build(network) is None, alias


def test_the_shipped_policy_drives_a_short_episode_with_the_forward():
    policy = controllers.make("policy")  # the shipped policy
    assert policy.forward is not None
    env = policy.wrap_env(base_env(policy.policy.config, time_limit=3.0))

    def actions() -> list[np.ndarray]:
        return [s.action for s in controllers.rollout(env, policy, seed=1000)
                if s.action is not None]

    try:
        first = actions()
        assert len(first) > 10 and all(a.shape == (2,) and a.dtype == np.float32
                                       and np.isfinite(a).all() for a in first)
        assert [a.tobytes() for a in actions()] == [a.tobytes() for a in first]
    finally:
        env.close()
