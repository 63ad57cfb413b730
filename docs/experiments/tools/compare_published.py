"""The baselines against ports of their published code, and their answer to light and dark
looming objects: the tables of docs/experiments/models-log.md, "Baselines".

For every preset that reproduces a published file (`lgmd_sim.models.reference.published`
.ORACLES), and for this project's first reading (preset ``v0.1``) against the same file:
on synthetic looming squares and simulated jitter clips, the correlation and the largest
difference of the membrane potentials, and the first frame above the threshold (0.8) of
each. Then the light/dark looming table of all five models at each of their presets (the
first is the default), and their selectivity at their defaults.

    .venv/bin/python docs/experiments/tools/compare_published.py
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim import models
from lgmd_sim.core.frames import to_grey
from lgmd_sim.models.reference.published import ORACLES
from lgmd_sim.signals import stimuli

THRESHOLD = 0.8
#: The files preset v0.1 was read from (ORACLES labels).
V01_READ_FROM = ("PI-LGMD models.py", "LGMDSingle.cs", "lgmd2OpenSource.cs",
                 "optimized_LGMD.py, PM_off bug fixed")


def simulated_clip(env_id: str, shape: tuple[int, int], seed: int) -> np.ndarray:
    """Grey frames of one episode driving straight ahead, until it ends."""
    env = gym.make(env_id, jitter=1.0, resolution=shape)
    obs, _ = env.reset(seed=seed)
    frames = [to_grey(obs["frame"])]
    while True:
        obs, _, terminated, truncated, _ = env.step(np.array([1.0, 0.0]))
        frames.append(to_grey(obs["frame"]))
        if terminated or truncated:
            env.close()
            return np.stack(frames)


def potentials(name: str, frames: np.ndarray, **params: object) -> np.ndarray:
    model = models.make(name, **params)
    return np.array([model.step(f).potential for f in frames])


def first_alarm(k: np.ndarray) -> str:
    above = np.flatnonzero(k > THRESHOLD)
    return str(above[0]) if above.size else "-"


def correlation(a: np.ndarray, b: np.ndarray) -> str:
    if a.std() == 0 or b.std() == 0:
        return "constant" if a.std() == b.std() else "-"
    return f"{np.corrcoef(a, b)[0, 1]:.4f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--seed", type=int, default=0, help="seed of the simulated episodes")
    args = ap.parse_args()
    shape = (args.height, args.width)
    clips = {
        "looming dark square": stimuli.approaching(
            shape, look=stimuli.Look(polarity="dark")).frames,
        "looming light square": stimuli.approaching(
            shape, look=stimuli.Look(polarity="light")).frames,
        "HandheldApproach, jitter 1": simulated_clip("lgmd_sim/HandheldApproach-v0", shape,
                                                     args.seed),
        "RoughTerrainObstacles, jitter 1": simulated_clip(
            "lgmd_sim/RoughTerrainObstacles-v0", shape, args.seed),
    }
    print(f"# {shape[0]}x{shape[1]}; looming squares: lgmd_sim.signals.stimuli.approaching "
          f"defaults (contrast 0.8, collision at frame 50); simulated clips: seed {args.seed}, "
          "driving straight, to the episode's end")
    print("# r, max |diff|: our membrane potential against the port of the published code; "
          "first alarm: first frame above 0.8 (ours / published)\n")
    print("| model | preset | published code | clip | frames | r | max \\|diff\\| "
          "| first alarm ours / published |")
    print("|---|---|---|---|---:|---:|---:|---|")
    for name, preset, params, oracle, kwargs, label in ORACLES:
        for clip_name, frames in clips.items():
            theirs = oracle(frames, **kwargs)
            # this project's first reading (v0.1) against the files it was read from
            v01 = ["v0.1"] if not params and label in V01_READ_FROM else []
            for ours_preset in [preset, *v01]:
                ours = potentials(name, frames, preset=ours_preset, **params)
                flags = "".join(f", {k}={v}" for k, v in params.items())
                print(f"| {name} | {ours_preset}{flags} | {label} | {clip_name} | {len(frames)} "
                      f"| {correlation(ours, theirs)} | {np.abs(ours - theirs).max():.2e} "
                      f"| {first_alarm(ours)} / {first_alarm(theirs)} |")

    print(f"\n# Light and dark looming squares at {shape[0]}x{shape[1]}, each model at each "
          "preset (the first is the default): first frame above 0.8, peak potential")
    for contrast in (0.8, 0.3):
        print(f"\ncontrast {contrast} (collision at frame 50)\n")
        print("| model | preset | dark: first alarm | dark: peak | light: first alarm "
              "| light: peak |")
        print("|---|---|---:|---:|---:|---:|")
        for name in models.available():
            for preset in models.presets_of(name):
                cells = []
                for polarity in ("dark", "light"):
                    look = stimuli.Look(polarity=polarity, contrast=contrast)
                    k = potentials(name, stimuli.approaching(shape, look=look).frames,
                                   preset=preset)
                    cells += [first_alarm(k), f"{k.max():.3f}"]
                print(f"| {name} | {preset} | " + " | ".join(cells) + " |")

    print(f"\n# Selectivity at {shape[0]}x{shape[1]}, contrast 0.3, each model at its default "
          "preset: a 0.2 m square approaching from 3 m at 2 m/s (collision at frame 50), "
          "receding from 1.5 to 3 m, translating at 3 m and 2 m/s\n")
    print("| model | polarity | approach: first alarm | approach: peak | receding: peak "
          "| translating: peak |")
    print("|---|---|---:|---:|---:|---:|")
    for name in models.available():
        for polarity in ("dark", "light"):
            look = stimuli.Look(polarity=polarity, contrast=0.3)
            app = potentials(name, stimuli.approaching(shape, look=look).frames)
            rec = potentials(name, stimuli.receding(shape, near_distance=1.5, end_distance=3.0,
                                                    look=look).frames)
            tra = potentials(name, stimuli.translating(shape, distance=3.0, speed=2.0,
                                                       look=look).frames)
            print(f"| {name} | {polarity} | {first_alarm(app)} | {app.max():.3f} "
                  f"| {rec.max():.3f} | {tra.max():.3f} |")


if __name__ == "__main__":
    main()
