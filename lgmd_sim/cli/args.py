"""Argument types shared by the subcommands: each rejects a bad value with a clear message."""

from __future__ import annotations

import argparse


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text}")
    return value


def non_negative_float(text: str) -> float:
    value = float(text)
    if not value >= 0:  # also rejects NaN
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text}")
    return value


def resolution(text: str) -> str | list[int]:
    """A named frame size (paper, rl, small) or HEIGHTxWIDTH."""
    from lgmd_sim.world.params import RESOLUTIONS, resolution_check

    if text in RESOLUTIONS:
        return text
    try:
        size = [int(v) for v in text.lower().split("x")]
    except ValueError:
        size = []
    if len(size) != 2 or resolution_check(size):
        raise argparse.ArgumentTypeError(
            f"must be {', '.join(RESOLUTIONS)} or HEIGHTxWIDTH (e.g. 270x480), got {text!r}")
    return size
