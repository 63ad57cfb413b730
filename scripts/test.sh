#!/usr/bin/env bash
# The test command: set up what is missing, then lint and run the test suite.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
ruff check lgmd_sim tests examples docs/experiments/tools scripts conftest.py
# On every core (pytest-xdist); "-n 0" among the arguments runs in this process alone.
python -m pytest -n auto "$@"
