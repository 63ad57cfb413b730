"""ISI (mean SSIM of consecutive frames, Eq. 21) per scenario at several jitter levels.

Drives straight ahead for up to --steps frames per episode, over --seeds seeds, and prints
a Markdown table: the mean ISI, and the RMS camera angular speed (the jitter itself).

    .venv/bin/python docs/experiments/tools/jitter_isi.py --resolution paper
"""

from __future__ import annotations

import argparse
import itertools

import gymnasium as gym
import numpy as np

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim.controllers import Straight, rollout
from lgmd_sim.envs.catalogue import scenarios


def measure(env_id: str, jitter: float, seeds: int, steps: int, resolution: str
            ) -> tuple[float, float]:
    """Mean ISI and RMS camera angular speed (rad/s) over `seeds` episodes."""
    isis, rates = [], []
    for seed in range(seeds):
        env = gym.make(env_id, resolution=resolution, jitter=jitter, ssim=True)
        frames = itertools.islice(rollout(env, Straight(heading_gain=0.0), seed=seed),
                                  1, steps + 1)  # the frames after the reset frame
        ssim, spin = zip(*((s.info["ssim"], np.linalg.norm(s.info["camera_angvel"]))
                           for s in frames), strict=True)
        env.close()
        isis.append(np.mean(ssim))
        rates.append(np.sqrt(np.mean(np.square(spin))))
    return float(np.mean(isis)), float(np.mean(rates))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--resolution", default="paper", help="paper, rl or small")
    parser.add_argument("--levels", default="0,0.5,1,2", help="comma-separated jitter levels")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=60)
    args = parser.parse_args()
    levels = [float(x) for x in args.levels.split(",")]
    print(f"ISI (RMS camera angular speed, rad/s) at {args.resolution}, {args.seeds} seeds x "
          f"up to {args.steps} frames, driving straight\n")
    print("| scenario | " + " | ".join(f"jitter {j:g}" for j in levels) + " |")
    print("|---|" + "---|" * len(levels))
    for name, sc in scenarios().items():
        cells = [measure(sc.env_id, j, args.seeds, args.steps, args.resolution) for j in levels]
        print(f"| {name} | " + " | ".join(f"{isi:.3f} ({w:.2f})" for isi, w in cells) + " |",
              flush=True)


if __name__ == "__main__":
    main()
