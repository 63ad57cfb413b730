"""What every test of the checkout needs before it is collected (tests/, scripts/tests/,
docs/experiments/tools/tests/): lgmd_sim imported before NumPy, so that the suite runs in
the default numeric mode, and a data folder of its own, so that it reads the shipped
calibrated presets only, never a user's (lgmd_sim.models.presets)."""

import atexit
import os
import shutil
import tempfile

import lgmd_sim  # noqa: F401

os.environ["LGMD_SIM_DATA_DIR"] = tempfile.mkdtemp(prefix="lgmd-sim-test-data-")
atexit.register(shutil.rmtree, os.environ["LGMD_SIM_DATA_DIR"], ignore_errors=True)
