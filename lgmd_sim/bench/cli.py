"""Checking the benchmark's command-line lists, then running it."""

from __future__ import annotations

import argparse
import math

__all__ = ["closed_loop", "open_loop", "parse_detectors", "parse_jitter", "parse_names"]


def parse_names(text: str, valid: list[str], what: str) -> list[str]:
    """A comma-separated list of names, each among `valid` ("all": every one)."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    if names == ["all"]:
        return list(valid)
    unknown = [n for n in names if n not in valid]
    if unknown or not names:
        raise ValueError(f"unknown {what} {', '.join(map(repr, unknown))}" if unknown else
                         f"no {what} given" + f"; valid: {', '.join(valid)}")
    return list(dict.fromkeys(names))


def parse_jitter(text: str) -> list[float]:
    from lgmd_sim.world.params import MAX_JITTER

    levels = []
    for item in text.split(","):
        try:
            level = float(item)
        except ValueError:
            level = math.nan
        if not 0 <= level <= MAX_JITTER:
            raise ValueError(f"jitter level {item.strip()!r} is not a number in "
                             f"[0, {MAX_JITTER:g}]")
        levels.append(level)
    return list(dict.fromkeys(levels))


def parse_detectors(models_text: str, presets_text: str | None) -> list[tuple[str, str]]:
    """(model, preset) pairs from --models (MODEL or MODEL/PRESET, or all) and --presets."""
    from lgmd_sim import models

    tokens = [t.strip() for t in models_text.split(",") if t.strip()]
    if tokens == ["all"]:
        tokens = models.available()
    presets = [p.strip() for p in (presets_text or "").split(",") if p.strip()]
    detectors = []
    for token in tokens:
        name, preset = models.parse_spec(token)
        have = [p for p in presets if p in models.model_class(name).presets]
        detectors += ([(name, p) for p in have] if have and "/" not in token
                      else [(name, preset)])
    if presets and not any(p in models.model_class(n).presets for n, _ in detectors
                           for p in presets):
        raise ValueError(f"no model listed has any of the presets {', '.join(presets)}")
    if not detectors:
        raise ValueError("no models given")
    return list(dict.fromkeys(detectors))


def closed_loop(args: argparse.Namespace) -> int:
    """Check every list, then run `lgmd_sim.bench.closed_loop.run`."""
    from lgmd_sim import controllers
    from lgmd_sim.bench import closed_loop
    from lgmd_sim.envs.catalogue import scenarios

    args.scenarios = parse_names(args.scenarios, list(scenarios()), "scenario(s)")
    args.controllers = parse_names(args.controllers, controllers.available(), "controller(s)")
    args.detectors = parse_detectors(args.models, args.presets)
    args.jitter = parse_jitter(args.jitter)
    if not (-1 <= args.cruise <= 1):
        raise ValueError(f"--cruise must be in [-1, 1], got {args.cruise}")
    if not (math.isfinite(args.horizon) and args.horizon > 0):
        raise ValueError(f"--horizon must be a number > 0, got {args.horizon}")
    return closed_loop.run(args)


def _levels(text: str) -> list[float]:
    levels = []
    for item in filter(None, (t.strip() for t in text.split(","))):
        try:
            level = float(item)
        except ValueError:
            level = -1.0
        if not 0 < level <= 1:
            raise ValueError(f"noise level {item!r} is not a number in (0, 1]")
        levels.append(level)
    return list(dict.fromkeys(levels))


def open_loop(args: argparse.Namespace) -> int:
    """Check every list, plan the clips, then run `lgmd_sim.bench.open_loop.run`."""
    from lgmd_sim.bench import open_loop
    from lgmd_sim.envs.catalogue import params_for, scenarios

    args.detectors = parse_detectors(args.models, args.presets)
    args.noise_levels = _levels(args.noise_levels)
    if not (math.isfinite(args.horizon) and args.horizon > 0):
        raise ValueError(f"--horizon must be a number > 0, got {args.horizon}")
    if not (math.isfinite(args.window) and args.window >= 0):
        raise ValueError(f"--window must be a number >= 0, got {args.window}")
    if args.dataset is not None:
        from lgmd_sim import data

        episodes = data.episodes(args.dataset)
        if episodes is None:
            raise ValueError(f"{args.dataset} is not a dataset (nor DIR:N, an episode of one)")
        args.clips = [open_loop.Clip(ep.scenario, ep.jitter, ep.seed, str(ep.root), ep.index)
                      for ep in episodes]
        tripods = {ep.scenario for ep in episodes
                   if params_for(ep.scenario, {}).carrier == "tripod"}
    else:
        names = parse_names(args.scenarios, list(scenarios()), "scenario(s)")
        jitters = parse_jitter(args.jitter)
        seeds = range(args.first_seed, args.first_seed + args.seeds)
        args.clips = [open_loop.Clip(sc, j, s) for sc in names for j in jitters for s in seeds]
        tripods = {sc for sc in names if params_for(sc, {}).carrier == "tripod"}
    # the paper's dataset (d): its stationary clips (a tripod, no jitter) with noise added
    args.noisy = {c.key for c in args.clips if c.scenario in tripods and c.jitter == 0}
    return open_loop.run(args)
