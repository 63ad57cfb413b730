"""Names that stand for classes: a registry maps each name to a ``"module:attr"`` string,
imported on first use, so that listing the names stays cheap and a module loads only when
one of its classes is asked for (the models, the controllers, the reference models)."""

from __future__ import annotations

from collections.abc import Mapping
from importlib import import_module
from typing import Any

__all__ = ["load", "lookup"]


def load(spec: str) -> Any:
    """The object a ``"package.module:attr"`` string names."""
    module, attr = spec.split(":")
    return getattr(import_module(module), attr)


def lookup(registry: Mapping[str, str], name: str, what: str) -> Any:
    """The object registered as `name`; ValueError naming the valid ones for another.

    Args:
        what: the kind of name, for the message ("model").
    """
    if name not in registry:
        raise ValueError(f"unknown {what} {name!r}; available: {', '.join(registry)}")
    return load(registry[name])
