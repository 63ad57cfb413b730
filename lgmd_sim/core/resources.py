"""Where the scenario catalogue (envs/) and the MJCF assets (assets/) are.

In a checkout (or an editable install) they sit beside the package; an installed wheel
carries them inside it as lgmd_sim/_data/ (see setup.py).
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parents[1]  # lgmd_sim/


def data_dir(name: str) -> Path:
    """Return the folder `name` ("envs" or "assets"), installed or from the checkout."""
    for candidate in (_PACKAGE / "_data" / name, _PACKAGE.parent / name):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"lgmd_sim data folder {name!r} not found in {_PACKAGE / '_data'} or {_PACKAGE.parent}: "
        "reinstall lgmd-sim"
    )


def envs_dir() -> Path:
    return data_dir("envs")


def assets_dir() -> Path:
    return data_dir("assets")
