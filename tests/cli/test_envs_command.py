"""`lgmd-sim envs`: a user's scenario file too large to be one breaks only itself."""

from __future__ import annotations

import os
import subprocess
import sys

import lgmd_sim  # noqa: F401 - registers the scenarios
from lgmd_sim.core import fileio
from lgmd_sim.envs import catalogue


def test_a_user_scenario_file_too_large_to_be_one_breaks_only_itself(tmp_path):
    # /dev/zero was read until the kernel killed the process, at import
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "Zero.toml").symlink_to("/dev/zero")
    with open(folder / "Huge.toml", "wb") as f:  # sparse: no disk, no time
        f.truncate(fileio.TEXT_LIMIT + 1)
    result = subprocess.run([sys.executable, "-m", "lgmd_sim.cli", "envs"],
                            env={**os.environ, catalogue.ENV_VAR: str(folder)},
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and "lgmd_sim/PassBy-v0" in result.stdout
    for name, why in (("Zero.toml", "not a regular file"), ("Huge.toml", "larger than")):
        (line,) = [x for x in result.stderr.splitlines() if name in x]
        assert str(folder / name) in line and why in line
