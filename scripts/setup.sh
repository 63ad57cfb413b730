#!/usr/bin/env bash
# Set-up for a fresh machine, safe to re-run: system GL libraries for offscreen MuJoCo
# rendering (if missing), a virtual environment in .venv, and lgmd-sim with its
# dependencies with every extra (torch pinned to the CPU build by constraints.txt). Sourced by
# scripts/demo.sh and scripts/test.sh.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

if ! ldconfig -p | grep -q 'libEGL_mesa.so.0'; then
  echo "setup: installing Mesa EGL (offscreen rendering)" >&2
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq \
    libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 libglx0 >/dev/null
fi

PY="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv" >&2
  "$PY" -m venv .venv
fi

# Reinstall only when the project's requirements changed since the last set-up.
stamp=".venv/.lgmd-sim-setup"
want="$(cat pyproject.toml setup.py constraints.txt | sha256sum | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  echo "setup: installing lgmd-sim and its dependencies into .venv" >&2
  log=".venv/pip-install.log"
  if ! .venv/bin/python -m pip install -q --disable-pip-version-check -c constraints.txt \
      -e ".[all]" >"$log" 2>&1; then
    grep -v '^WARNING: Location' "$log" >&2
    echo "setup: pip install failed (full log: $log)" >&2
    exit 1
  fi
  echo "$want" > "$stamp"
fi
export PATH="$ROOT/.venv/bin:$PATH"
