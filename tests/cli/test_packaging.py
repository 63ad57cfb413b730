"""A wheel built from the checkout carries the scenario catalogue and the assets, and
works, with every command and code block of the documents, outside the checkout."""

from __future__ import annotations

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
# A ```python block must run as it stands, from the wheel; ```py marks an excerpt, or code
# that needs a module of the checkout (a test plug-in) on the path.
PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
BLOCKS = [(doc, code) for doc in DOCS for code in PYTHON_BLOCK.findall(doc.read_text())]


def test_wheel_carries_envs_assets_and_markers(wheel):
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
    assert {"lgmd_sim/cli/__init__.py", "lgmd_sim/py.typed"} <= set(names)
    modules = {p.relative_to(ROOT).as_posix() for p in (ROOT / "lgmd_sim").rglob("*.py")}
    assert not modules - set(names), "modules missing from the wheel (a folder without "\
        "__init__.py?)"
    from lgmd_sim import policies

    for name in policies.available():  # the shipped policies, each a whole policy folder
        assert {f"lgmd_sim/policies/{name}/{f}" for f in ("policy.npz", "policy.json",
                                                         "POLICY.md")} <= set(names)
    assert policies.DEFAULT in policies.available()
    assert any(n.endswith(".dist-info/licenses/LICENSE") or n.endswith("/LICENSE")
               for n in names)


@pytest.mark.slow
def test_installed_wheel_works_outside_the_checkout(installed, tmp_path):
    code = (
        "import gymnasium as gym, lgmd_sim, lgmd_sim.core.resources as r;"
        "print(lgmd_sim.__file__); print(r.envs_dir()); print(r.assets_dir());"
        "env = gym.make('lgmd_sim/StationaryApproach-v0', resolution=[32, 48]);"
        "obs, info = env.reset(seed=0); env.close(); print(obs['frame'].shape)"
    )
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True, env=installed)  # lgmd_sim picks the GL backend
    assert result.returncode == 0, result.stderr
    package, envs, assets, shape = result.stdout.split("\n")[:4]
    target = installed["PYTHONPATH"]
    for path in (package, envs, assets):
        assert path.startswith(target), path
    assert shape == "(32, 48, 3)"


@pytest.mark.parametrize(("doc", "code"), BLOCKS,
                         ids=[f"{d.relative_to(ROOT)}-{i}" for i, (d, _c) in enumerate(BLOCKS)])
@pytest.mark.slow
def test_every_python_block_of_the_documents_runs(installed, tmp_path, doc, code):
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True, env=installed, timeout=120)
    assert result.returncode == 0, f"{doc.name}:\n{code}\n{result.stderr}"


@pytest.mark.slow
def test_the_video_guide_s_record_and_detect_walkthrough_runs(installed, tmp_path):
    """The video guide's `lgmd-sim record` then `lgmd-sim detect` block, verbatim, from the
    wheel: the printed collision frame is the one the detect line uses."""
    guide = (ROOT / "docs" / "guides" / "video.md").read_text()
    block = next(b for b in re.findall(r"^```bash\n(.*?)^```", guide, re.S | re.M)
                 if "lgmd-sim record" in b)
    lines = [ln for ln in block.splitlines() if ln.startswith("lgmd-sim")]
    record = subprocess.run(lines[0].split(), cwd=tmp_path, capture_output=True, text=True,
                            env=installed, timeout=300)
    assert record.returncode == 0, record.stderr
    expected = next(ln[2:] for ln in block.splitlines() if ln.startswith("# wrote"))
    assert record.stdout.splitlines()[0] == expected
    detect = subprocess.run(lines[1].split(), cwd=tmp_path, capture_output=True, text=True,
                            env=installed, timeout=300)
    assert detect.returncode == 0, detect.stderr
    assert (tmp_path / "docs" / "detect" / "handheld.png").stat().st_size > 10_000
    version = subprocess.run(["lgmd-sim", "--version"], capture_output=True, text=True,
                             env=installed, check=True)
    import lgmd_sim

    assert version.stdout.strip() == f"lgmd-sim {lgmd_sim.__version__}"


def test_the_api_reference_states_the_observation_spaces_the_environment_has():
    """The API reference's comment lines `# obs["KEY"]: dtype (shape)` match the main task's
    observation space: every key, its dtype, and its shape (the frame's as (H, W, 3))."""
    import gymnasium as gym

    import lgmd_sim  # noqa: F401  (registers the scenarios)

    page = (ROOT / "docs" / "reference" / "api.md").read_text()
    stated = {key: (dtype, shape) for key, dtype, shape in
              re.findall(r'^# obs\["(\w+)"\]:\s+(\w+) \(([^)]*)\)', page, re.M)}
    env = gym.make("lgmd_sim/RoughTerrainObstacles-v0", resolution="rl")
    try:
        spaces = env.observation_space.spaces
    finally:
        env.close()
    assert sorted(stated) == sorted(spaces)
    for key, (dtype, shape) in stated.items():
        assert dtype == spaces[key].dtype.name, key
        dims = [d.strip() for d in shape.split(",") if d.strip()]
        assert len(dims) == len(spaces[key].shape), key
        sizes = zip(dims, spaces[key].shape, strict=True)
        assert all(not d.isdigit() or int(d) == n for d, n in sizes), key
