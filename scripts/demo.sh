#!/usr/bin/env bash
# The main demo: set up what is missing, then run `lgmd-sim demo` (see README.md).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
lgmd-sim demo "$@"
