"""Record a scenario's camera stream as an MP4, driving straight ahead.

Prints the frame of first collision (the label `lgmd-sim detect --collision-frame`
takes). The README uses it to make a clip to run `lgmd-sim detect` on:

    .venv/bin/python scripts/record_clip.py HandheldApproach docs/handheld.mp4 --seed 3
"""

from __future__ import annotations

import argparse

import cv2
import gymnasium as gym
import numpy as np

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim.envs.catalogue import scenario
from lgmd_sim.fileio import atomic_output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", help="catalogue name, e.g. HandheldApproach")
    parser.add_argument("out", help="MP4 file to write")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jitter", type=float, default=None, help="override the jitter level")
    args = parser.parse_args()
    overrides = {} if args.jitter is None else {"jitter": args.jitter}
    env = gym.make(scenario(args.scenario).env_id, resolution="paper", **overrides)
    obs, info = env.reset(seed=args.seed)
    frames, collision = [obs["frame"]], None
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(np.array([1.0, 0.0]))
        frames.append(obs["frame"])
        if info["collision"] and collision is None:
            collision = len(frames) - 1
        done = terminated or truncated
    fps = env.metadata["render_fps"]
    env.close()
    h, w = frames[0].shape[:2]
    with atomic_output(args.out) as tmp:
        writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
        for f in frames:
            writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
        writer.release()
    print(f"wrote {args.out}: {len(frames)} frames at {fps:g} fps, collision frame {collision}")


if __name__ == "__main__":
    main()
