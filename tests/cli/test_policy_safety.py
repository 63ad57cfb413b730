"""Policies as inputs from anyone: a bad policy is refused before `lgmd-sim bench closed-loop
--policies` makes its run folder, and a policy folder is data, never code (no pickle is
loaded from it)."""

from __future__ import annotations

import base64
import io
import json
import pickle
import shutil
import sys
import zipfile
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.lib import format as npy

pytest.importorskip("stable_baselines3")

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import cli, policies
from lgmd_sim.policies.observe import base_env, observe
from lgmd_sim.training.run import TrainConfig

ENV = "lgmd_sim/StationaryApproach-v0"


@contextmanager
def _untrained(config):
    """An untrained PPO model of `config`'s observations, while its environment is open."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: observe(base_env(config), config)])
    try:
        yield PPO("MultiInputPolicy", venv, n_steps=64, batch_size=64, seed=0, device="cpu",
                  policy_kwargs={"net_arch": [8, 8]})
    finally:
        venv.close()


@pytest.fixture(scope="module")
def model():
    """An untrained PPO model on the tripod scenario at 64 x 64, and its PolicyConfig."""
    config = TrainConfig(algo="ppo", env=ENV, resolution="small").policy()
    with _untrained(config) as ppo:
        yield ppo, config


@pytest.fixture(scope="module")
def good(model, tmp_path_factory):
    """The policy folder of `model`, as lgmd-sim train saves one."""
    return policies.save(tmp_path_factory.mktemp("policy") / "tiny", *model,
                         policies.Normalizer(), steps=0)


def _eval(policy, out) -> int:
    return cli.main(["bench", "closed-loop", "--policies", str(policy), "--controllers", "none",
                     "--jitter", "1", "--seeds", "1", "--workers", "1", "--out", str(out),
                     "--no-progress"])


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


def test_the_policies_help_says_they_need_the_rl_extra_and_which_files_are_pickles(capsys):
    with pytest.raises(SystemExit):
        cli.main(["bench", "closed-loop", "--help"])
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


# --- issue 39: a policy.json names nothing that runs, and nothing of a size not checked ----

PLUGINS = Path(__file__).resolve().parents[1] / "plugins"
#: A module a hostile policy ships beside policy.json: importing it leaves a marker.
LGMDEXT = "from pathlib import Path\nPath(__file__).with_name('ran').write_text('imported')\n"


def _hostile(good, folder, spec):
    """`good` copied to `folder` with lgmdext.py beside it and policy.json naming `spec`."""
    shutil.copytree(good, folder)
    (folder / "lgmdext.py").write_text(LGMDEXT)
    _edit_json(folder, lambda d: d["config"].update(model=spec))
    return folder


@pytest.mark.parametrize("inside", [True, False], ids=["inside", "outside"])
@pytest.mark.parametrize("spec", ["lgmdext:X", "this:X"])
def test_a_model_a_policy_names_as_a_module_runs_none_of_it_from_the_cli_and_the_api(
        good, tmp_path, monkeypatch, capsys, fresh_registries, spec, inside):
    folder = _hostile(good, tmp_path / "hostile", spec)
    monkeypatch.delitem(sys.modules, "this", raising=False)
    monkeypatch.delitem(sys.modules, "lgmdext", raising=False)
    if inside:  # as `python -c` run in the folder: the folder first on sys.path
        monkeypatch.chdir(folder)
        monkeypatch.syspath_prepend("")
    where = Path(".") if inside else folder
    with pytest.raises(ValueError, match=r"policy\.json: config\.model") as api:
        policies.load(where)
    assert len(str(api.value).splitlines()) == 1
    assert _eval(where, tmp_path / "eval") == 2
    out, err = capsys.readouterr()
    assert len(err.strip().splitlines()) == 1 and "policy.json: config.model" in err, err
    assert "Beautiful is better than ugly" not in out + err
    assert not (folder / "ran").exists()
    assert "this" not in sys.modules and "lgmdext" not in sys.modules
    assert not (tmp_path / "eval" / "run.json").exists()


def test_a_plug_in_the_user_names_or_registers_is_observed(model, tmp_path, monkeypatch,
                                                           fresh_registries):
    from lgmd_sim import models

    monkeypatch.syspath_prepend(str(PLUGINS))
    # the plug-in has no S layer: no grid
    config = replace(model[1], model="lgmd_plug:Blink", preset="plain", grid=None)
    with _untrained(config) as ppo:
        folder = policies.save(tmp_path / "blink", ppo, config, policies.Normalizer())
    with pytest.raises(ValueError, match=r"config\.model 'lgmd_plug:Blink'"):
        policies.load(folder)
    loaded = policies.load(folder, plugins=("lgmd_plug:Blink",))
    assert loaded.config.model == "lgmd_plug:Blink"
    # from the command line: --models names it, for the policy's cells too
    assert cli.main(["bench", "closed-loop", "--policies", str(folder), "--models",
                     "lgmd_plug:Blink", "--controllers", "none", "--jitter", "1", "--seeds", "1",
                     "--workers", "1", "--out", str(tmp_path / "eval"), "--no-progress"]) == 0
    models.register("blink", "lgmd_plug:Blink")  # a name the user registered themselves
    _edit_json(folder, lambda d: d["config"].update(model="blink"))
    assert policies.load(folder).config.model == "blink"


#: An array of every policy's network (the log standard deviation of its actions).
ARRAY = "log_std"


def _declaring(shape):
    """policy.npz's `ARRAY` replaced by one whose header declares `shape` (float32), with a
    few bytes of data."""
    header = io.BytesIO()
    npy.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False,
                                        "shape": shape})
    declared = header.getvalue() + bytes(16)
    return lambda folder: _rezip(folder / "policy.npz", lambda name, data: (
        declared if name == f"{ARRAY}.npy" else data))


def _weights_with_nan(folder):
    weights = dict(np.load(folder / "policy.npz"))
    weights[ARRAY][..., 0] = np.nan
    np.savez(folder / "policy.npz", **weights)


def _statistics(**changes):
    """Statistics that fit the observation (the alarm's), with `changes`."""
    stats = {"clip": 10.0, "epsilon": 1e-8, "mean": {"lgmd_alarm": [0.0]},
             "var": {"lgmd_alarm": [1.0]}, **changes}
    return lambda f: _edit_json(f, lambda d: d.update(normalize=stats))


def _oversized(folder):
    with (folder / "policy.json").open("r+b") as f:  # sparse: nothing is written
        f.truncate(65 * 2**20)


def _config(**changes):
    return lambda f: _edit_json(f, lambda d: d["config"].update(changes))


#: Impossible numbers, sizes and names: (corruption, the file, what of it the line names).
REFUSED_AT_LOAD = {
    "an array declaring 1e12 values": (_declaring((10**12,)), "policy.npz", repr(ARRAY)),
    "NaN weights": (_weights_with_nan, "policy.npz", repr(ARRAY)),
    "a NaN clip": (_statistics(clip=float("nan")), "policy.json", "clip"),
    "a negative variance": (_statistics(var={"lgmd_alarm": [-1.0]}), "policy.json",
                            "var['lgmd_alarm']"),
    "an infinite mean": (_statistics(mean={"lgmd_alarm": [float("inf")]}), "policy.json",
                         "mean['lgmd_alarm']"),
    "a grid of more cells than pixels": (_config(grid=[10000, 10000]), "policy.json",
                                         "grid 10000x10000"),
    "a history of 1e9": (_config(history=10**9), "policy.json", "history=1000000000"),
    "a memory of -5 frames": (_config(memory=-5), "policy.json", "memory must be"),
    "frames of 1e6 x 1e6": (_config(obs="pixels", model=None, frame_size=[10**6] * 2),
                            "policy.json", "size"),
    "another kind of environment": (_config(env_id="CartPole-v1"), "policy.json",
                                    "config.env_id 'CartPole-v1'"),
    "a preset that is no name": (_config(preset=["paper"]), "policy.json", "config.preset"),
    "a policy.json of 65 MB": (_oversized, "policy.json", "larger than"),
}


@pytest.mark.parametrize(("corrupt", "file", "named"), REFUSED_AT_LOAD.values(),
                         ids=REFUSED_AT_LOAD)
def test_impossible_values_are_refused_at_load_naming_the_file_and_key(
        good, tmp_path, capsys, corrupt, file, named):
    bad = tmp_path / "tiny"
    shutil.copytree(good, bad)
    corrupt(bad)
    with pytest.raises(ValueError) as api:
        policies.load(bad)
    line = str(api.value)
    assert len(line.splitlines()) == 1 and str(bad / file) in line and named in line, line
    assert _eval(bad, tmp_path / "eval") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad / file) in err and named in err, err
    assert not (tmp_path / "eval" / "run.json").exists()
