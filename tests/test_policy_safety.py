"""Policies as inputs from anyone: a bad policy is refused before `lgmd-sim eval` makes its
run folder, and a policy folder is data, never code (no pickle is loaded from it)."""

from __future__ import annotations

import base64
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import cli, policies
from lgmd_sim.policies.observe import base_env, observe
from lgmd_sim.training.run import TrainConfig

ENV = "lgmd_sim/StationaryApproach-v0"


@pytest.fixture(scope="module")
def model():
    """An untrained PPO model on the tripod scenario at 64 x 64, and its PolicyConfig."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    config = TrainConfig(algo="ppo", env=ENV, resolution="small").policy()
    venv = DummyVecEnv([lambda: observe(base_env(config), config)])
    yield PPO("MultiInputPolicy", venv, n_steps=64, batch_size=64, seed=0, device="cpu",
              policy_kwargs={"net_arch": [8, 8]}), config
    venv.close()


@pytest.fixture(scope="module")
def good(model, tmp_path_factory):
    """The policy folder of `model`, as lgmd-sim train saves one."""
    return policies.save(tmp_path_factory.mktemp("policy") / "tiny", *model,
                         policies.Normalizer(), steps=0)


def _eval(policy, out) -> int:
    return cli.main(["eval", str(policy), "--controllers", "none", "--jitter", "1", "--seeds",
                     "1", "--workers", "1", "--out", str(out), "--no-progress"])


def _edit_json(folder, edit) -> None:
    data = json.loads((folder / "policy.json").read_text())
    edit(data)
    (folder / "policy.json").write_text(json.dumps(data))


def _misshapen(folder) -> None:
    weights = dict(np.load(folder / "policy.npz"))
    first = next(iter(weights))
    weights[first] = weights[first][:1]
    np.savez(folder / "policy.npz", **weights)


CORRUPTIONS = {
    "not an archive": lambda f: (f / "policy.npz").write_bytes(b"not a zip"),
    "misshapen weights": _misshapen,
    "statistics of another shape": lambda f: _edit_json(f, lambda d: d.update(normalize={
        "clip": 10.0, "epsilon": 1e-8, "mean": {"goal": [0.0]}, "var": {"goal": [1.0]}})),
    "an unknown network argument": lambda f: _edit_json(
        f, lambda d: d["network"]["kwargs"].update(warp=9)),
    "an unknown algorithm": lambda f: _edit_json(f, lambda d: d["config"].update(algo="dqn")),
}


@pytest.mark.parametrize("corrupt", CORRUPTIONS.values(), ids=CORRUPTIONS)
def test_a_bad_policy_leaves_no_run_folder(good, tmp_path, capsys, corrupt):
    bad = tmp_path / "tiny"
    shutil.copytree(good, bad)
    corrupt(bad)
    out = tmp_path / "eval"
    assert _eval(bad, out) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad / "policy.") in err, err
    assert "allow_pickle" not in err  # NumPy's advice to unpickle is not passed on
    assert not (out / "run.json").exists()


def test_the_rerun_after_fixing_a_corrupt_policy_needs_no_resume(good, tmp_path):
    bad = tmp_path / "tiny"
    shutil.copytree(good, bad)
    (bad / "policy.npz").write_bytes(b"not a zip")
    out = tmp_path / "eval"
    assert _eval(bad, out) == 2
    shutil.copytree(good, bad, dirs_exist_ok=True)  # the policy fixed
    assert _eval(bad, out) == 0


class _Payload:
    """What a hostile policy's author pickles: unpickling it writes `marker`."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (Path.write_text, (self.marker, "unpickled"))


def _hostile_sb3_zip(file, marker) -> None:
    """A stable-baselines3 model file whose "data" entry carries a cloudpickled payload,
    where SB3 keeps the observation space."""
    payload = base64.b64encode(pickle.dumps(_Payload(marker))).decode()
    with zipfile.ZipFile(file, "w") as z:
        z.writestr("data", json.dumps({"observation_space": {":type:": "<class 'x'>",
                                                             ":serialized:": payload}}))
        z.writestr("_stable_baselines3_version", "2.9.2")


def test_a_policy_folder_s_pickles_are_never_loaded(good, tmp_path, capsys):
    marker = tmp_path / "pwned"
    hostile = tmp_path / "hostile"
    shutil.copytree(good, hostile)
    for name in ("policy.npz", "policy.zip"):
        (hostile / name).unlink(missing_ok=True)
    _hostile_sb3_zip(hostile / "policy.zip", marker)
    with pytest.raises(ValueError, match="pickle"):
        policies.load(hostile)
    assert _eval(hostile, tmp_path / "eval") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "pickle" in err, err
    # the weights file itself holding a pickle (an object array) is refused too
    (hostile / "policy.zip").unlink()
    np.save(hostile / "weights.npy", np.array([_Payload(marker)], dtype=object),
            allow_pickle=True)
    (hostile / "weights.npy").rename(hostile / "policy.npz")
    with pytest.raises(ValueError, match=r"policy\.npz"):
        policies.load(hostile)
    assert not marker.exists()


def test_the_safe_format_round_trips_and_carries_no_pickle(model, good):
    assert sorted(p.name for p in good.iterdir()) == ["policy.json", "policy.npz"]
    sb3, config = model
    loaded = policies.load(good)
    env = observe(base_env(config), config)
    obs, _ = env.reset(seed=3)
    for _ in range(5):
        ours, _ = loaded.network.predict(obs, deterministic=True)
        theirs, _ = sb3.predict(obs, deterministic=True)
        np.testing.assert_array_equal(ours, theirs)
        obs, *_ = env.step(ours)
    env.close()


def test_eval_help_says_it_needs_the_rl_extra_and_which_files_are_pickles(capsys):
    with pytest.raises(SystemExit):
        cli.main(["eval", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "rl extra" in text
    assert "pickle" in text and "checkpoints" in text and "trust" in text


def test_a_policy_naming_a_module_to_import_is_refused(good, tmp_path):
    odd = tmp_path / "odd"
    shutil.copytree(good, odd)
    data = json.loads((odd / "policy.json").read_text())
    data["config"]["env_id"] = "json:Anything-v0"  # gym.make would import the module
    (odd / "policy.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match="'json:Anything-v0' is not registered"):
        policies.load(odd)


def _older(model, good, folder):
    """A policy folder of the earlier format: `model`'s policy.zip beside `good`'s
    policy.json without its network."""
    folder.mkdir()
    model[0].save(folder / "policy.zip")
    data = json.loads((good / "policy.json").read_text())
    del data["network"]
    (folder / "policy.json").write_text(json.dumps(data))
    return folder


def test_an_older_folder_converts_to_the_same_actions(model, good, tmp_path, capsys):
    from lgmd_sim.policies import convert

    sb3, config = model
    older = _older(model, good, tmp_path / "older")
    with pytest.raises(ValueError, match="convert"):
        policies.load(older)
    convert.main([str(older)])
    assert "converted" in capsys.readouterr().out
    loaded = policies.load(older)
    env = observe(base_env(config), config)
    obs, _ = env.reset(seed=4)
    for _ in range(5):
        ours, _ = loaded.network.predict(obs, deterministic=True)
        np.testing.assert_array_equal(ours, sb3.predict(obs, deterministic=True)[0])
        obs, *_ = env.step(ours)
    env.close()


def _rezip(file, edit) -> None:
    """Rewrite the zip `file` with each member's bytes through `edit` (None: dropped)."""
    with zipfile.ZipFile(file) as z:
        members = {name: edit(name, z.read(name)) for name in z.namelist()}
    with zipfile.ZipFile(file, "w") as z:
        for name, data in members.items():
            if data is not None:
                z.writestr(name, data)


def _pickled_space(name, data):
    if name != "data":
        return data
    return json.dumps({**json.loads(data), "observation_space": {
        ":type:": "<class 'x'>", ":serialized:": "AAAA"}}).encode()


OLDER_CORRUPTIONS = {
    "not a zip": lambda f: (f / "policy.zip").write_bytes(b"not a zip"),
    "no data": lambda f: _rezip(f / "policy.zip", lambda n, d: None if n == "data" else d),
    "truncated weights": lambda f: _rezip(
        f / "policy.zip", lambda n, d: d[:3] if n.endswith(".pth") else d),
    "a pickle that is not one": lambda f: _rezip(f / "policy.zip", _pickled_space),
    "statistics without var": lambda f: _edit_json(
        f, lambda d: d.update(normalize={"mean": {"goal": [0.0]}})),
    "statistics of numbers": lambda f: _edit_json(
        f, lambda d: d.update(normalize={"mean": 3, "var": 1, "clip": 1, "epsilon": 1})),
}


@pytest.mark.parametrize("corrupt", OLDER_CORRUPTIONS.values(), ids=OLDER_CORRUPTIONS)
def test_converting_a_corrupt_older_folder_is_one_line_naming_its_file(model, good, tmp_path,
                                                                     capsys, corrupt):
    from lgmd_sim.policies import convert

    older = _older(model, good, tmp_path / "older")
    corrupt(older)
    with pytest.raises(SystemExit) as exc:
        convert.main([str(older)])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2
    assert len(err.splitlines()) == 1 and str(older / "policy.") in err, err
    assert not (older / "policy.npz").exists()
