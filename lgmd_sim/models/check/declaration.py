"""The checks of what a model's class declares, before it steps a frame: that it is an
`LGMDModel` with the hooks and class attributes (`_class`), that its parameters have
defaults, sources and checks and its presets build (`_parameters`), and that its search
space draws candidates that build (`_search_space`).
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping

import numpy as np

from lgmd_sim.models.base import LGMDModel, ModelParams, reserved_fault
from lgmd_sim.models.check.probe import _fail, _Subject
from lgmd_sim.models.search import check_search_space, draw_search

#: Candidates the search-space check draws and builds.
_CANDIDATES = 5


def _class(s: _Subject) -> None:
    """an LGMDModel subclass implementing the hooks, with name, layer_names, presets and
    Params"""
    cls = s.cls
    if not (isinstance(cls, type) and issubclass(cls, LGMDModel)):
        _fail(f"{cls!r} is not a subclass of LGMDModel")
    if inspect.isabstract(cls):
        _fail(f"it does not implement {', '.join(sorted(cls.__abstractmethods__))}")
    if not isinstance(getattr(cls, "name", None), str) or not cls.name:
        _fail("it has no name (a class attribute: the model's name in messages)")
    names = getattr(cls, "layer_names", None)
    if not (isinstance(names, tuple) and all(isinstance(n, str) and n for n in names)
            and len(set(names)) == len(names)):
        _fail(f"layer_names must be a tuple of distinct names (() for none), got {names!r}")
    presets = cls.presets
    if not (isinstance(presets, Mapping) and presets and all(
            isinstance(k, str) and isinstance(v, Mapping) for k, v in presets.items())):
        _fail("presets must map preset names to parameter overrides, the default first, "
              f"got {presets!r}")
    params = getattr(cls, "Params", None)
    if not (isinstance(params, type) and issubclass(params, ModelParams)
            and dataclasses.is_dataclass(params)):
        _fail(f"Params must be a dataclass subclassing ModelParams, got {params!r}")


def _parameters(s: _Subject) -> None:
    """every parameter has a default, a source and a check, which its default passes;
    every preset builds"""
    reserved = reserved_fault(s.cls.Params)
    if reserved:
        _fail(reserved)
    declare = "declare it with lgmd_sim.core.params.param(default, source, check=...)"
    for f in dataclasses.fields(s.cls.Params):
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            _fail(f"parameter {f.name} has no default: {declare}")
        source = f.metadata.get("source")
        if not (isinstance(source, str) and source.strip()):
            _fail(f"parameter {f.name} has no source (where its default comes from): {declare}")
        check = f.metadata.get("check")
        if not callable(check):
            _fail(f"parameter {f.name} has no check: {declare}")
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        error = check(default)
        if error:
            _fail(f"parameter {f.name}'s default {default!r} fails its own check: {error}")
    for preset, overrides in s.cls.presets.items():
        try:
            s.cls.Params(**overrides)
        except (TypeError, ValueError) as exc:
            _fail(f"preset {preset!r} does not build: {exc}")
    s.build()


def _search_space(s: _Subject) -> str | None:
    """the search_space names parameters, or every element of tuple ones, each a
    SearchRange, and its candidates build (skipped for a model without one)"""
    space = s.cls.search_space
    if isinstance(space, Mapping) and not space:
        return "no search_space"
    try:
        check_search_space(s.cls.name, s.cls.Params, space)
    except ValueError as exc:
        _fail(str(exc))
    rng, start = np.random.default_rng(s.seed), next(iter(s.cls.presets.values()))
    for _ in range(_CANDIDATES):
        drawn = draw_search(space, rng)
        try:
            s.cls.Params(**{**start, **drawn})
        except (TypeError, ValueError) as exc:
            _fail(f"the candidate {drawn} (the default preset with the drawn values) does "
                  f"not build: {exc}")
    return None
