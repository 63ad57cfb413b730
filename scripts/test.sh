#!/usr/bin/env bash
# The test command: set up what is missing, then lint and run the test suite.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
ruff check lgmd_sim tests examples docs/experiments/tools
python -m pytest "$@"
