"""A wheel built from the checkout carries the scenario catalogue and the assets."""

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_wheel_carries_envs_and_assets(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(tmp_path), str(ROOT)],
        check=True, capture_output=True,
    )
    (wheel,) = tmp_path.glob("lgmd_sim-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    catalogue = sorted(n for n in names if n.startswith("lgmd_sim/_data/envs/"))
    expected = sorted(p.name for p in (ROOT / "envs").glob("*.toml"))
    assert [Path(n).name for n in catalogue] == expected
    assert catalogue, "no scenario files in the wheel"
    shipped_assets = {n for n in names if n.startswith("lgmd_sim/_data/assets/")}
    for path in (ROOT / "assets").rglob("*"):
        if path.is_file():
            relative = path.relative_to(ROOT / "assets").as_posix()
            assert f"lgmd_sim/_data/assets/{relative}" in shipped_assets
    assert "lgmd_sim/cli.py" in names


def test_installed_wheel_works_outside_the_checkout(tmp_path):
    wheels, target, elsewhere = tmp_path / "wheels", tmp_path / "site", tmp_path / "cwd"
    elsewhere.mkdir()
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(wheels), str(ROOT)],
        check=True, capture_output=True,
    )
    (wheel,) = wheels.glob("lgmd_sim-*.whl")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
         str(wheel)],
        check=True, capture_output=True,
    )
    code = (
        "import gymnasium as gym, lgmd_sim, lgmd_sim.resources as r;"
        "print(lgmd_sim.__file__); print(r.envs_dir()); print(r.assets_dir());"
        "env = gym.make('lgmd_sim/StationaryApproach-v0', resolution=[32, 48]);"
        "obs, info = env.reset(seed=0); env.close(); print(obs['frame'].shape)"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=elsewhere, capture_output=True, text=True,
        env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"},  # lgmd_sim picks the GL
    )
    assert result.returncode == 0, result.stderr
    package, envs, assets, shape = result.stdout.split("\n")[:4]
    for path in (package, envs, assets):
        assert path.startswith(str(target)), path
    assert shape == "(32, 48, 3)"
