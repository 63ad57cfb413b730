"""Contact sheet of every scenario, and of the robot on flat vs rough ground.

One row per scenario of the catalogue (`lgmd-sim envs`): six frames of an episode at
270 x 480 (shown at half size), driving straight ahead, spread from the first frame to 0.5 s
before the first collision (a scenario that goes on after one, as ArenaRoam does, would
otherwise show the robot pressed against what it hit), or to the last frame. Two more rows:
six consecutive frames of the robot on flat ground (jitter 0) and on rough ground
(jitter 1), with a fixed yellow reference line across each frame, so the horizon visibly
jumps against it only on rough ground. The PNG records the command and the scenarios
(`lgmd_sim.core.pngtext`).

    .venv/bin/python docs/experiments/tools/contact_sheet.py --out docs/contact_sheet.png
"""

from __future__ import annotations

import argparse

import cv2
import gymnasium as gym
import numpy as np

import lgmd_sim  # noqa: F401  (registers the scenarios)
from lgmd_sim.controllers import Straight, rollout
from lgmd_sim.core.fileio import atomic_output
from lgmd_sim.core.pngtext import add_text, png_text
from lgmd_sim.envs.catalogue import scenarios

CELL = (240, 135)  # width, height of one frame on the sheet
#: Frames shown per scenario.
SHOWN = 6
#: The default first seed.
SEED = 10


def label(img: np.ndarray, text: str) -> np.ndarray:
    img = img.copy()
    (w, h), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.38, 1)
    img[: h + 8, : w + 6] = (img[: h + 8, : w + 6] * 0.35).astype(np.uint8)
    cv2.putText(img, text, (3, h + 3), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (255, 255, 255), 1,
                cv2.LINE_AA)
    return img


def episode(env_id: str, seed: int, **overrides) -> tuple[list[np.ndarray], list[dict], float]:
    """An episode driving straight ahead: its frames, infos and frame rate."""
    env = gym.make(env_id, resolution="paper", ssim=True, **overrides)
    steps = list(rollout(env, Straight(heading_gain=0.0), seed=seed))
    env.close()
    return ([s.obs["frame"] for s in steps], [s.info for s in steps],
            float(env.metadata["render_fps"]))


def small(frame: np.ndarray) -> np.ndarray:
    return cv2.resize(frame, CELL, interpolation=cv2.INTER_AREA)


def shown_frames(infos: list[dict], fps: float, n: int = SHOWN) -> list[int]:
    """The `n` frames a scenario's row shows: spread from the first to 0.5 s before the
    first collision, or to the last frame where there is none (after a collision a
    scenario that goes on shows the robot pressed against what it hit)."""
    hit = next((i for i, info in enumerate(infos) if info["collision"]), None)
    last = len(infos) - 1 if hit is None else max(hit - round(fps / 2), 0)
    return [int(i) for i in np.linspace(0, last, n).astype(int)]


def command(out: str, seed: int) -> str:
    """The command line that makes the sheet."""
    return (f"python docs/experiments/tools/contact_sheet.py --out {out}"
            + (f" --seed {seed}" if seed != SEED else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="docs/contact_sheet.png", help="PNG to write")
    parser.add_argument("--seed", type=int, default=SEED, help="first episode seed")
    args = parser.parse_args()
    rows, shown = [], {}
    for k, (name, sc) in enumerate(scenarios().items()):
        frames, infos, fps = episode(sc.env_id, seed=args.seed + k)
        picked = shown_frames(infos, fps)
        shown[name] = picked
        isi = np.mean([i["ssim"] for i in infos[1:picked[-1] + 1]])
        cells = []
        for i in picked:
            text = f"{name} ISI {isi:.2f} f{i}" if i == 0 else f"f{i}"
            if infos[i]["collision"]:
                text += " collision"
            cells.append(label(small(frames[i]), text))
        rows.append(np.hstack(cells))
    for jitter in (0.0, 1.0):
        frames, infos, _ = episode("lgmd_sim/RoughTerrainObstacles-v0", seed=args.seed,
                                   jitter=jitter, n_obstacles=0, obstacle_ahead=0.0)
        cells = []
        for i in range(40, 46):
            cell = small(frames[i])
            cell[CELL[1] // 2] = (255, 255, 0)  # fixed reference line
            rate = np.linalg.norm(infos[i]["camera_angvel"])
            text = (f"robot, jitter {jitter:g}: f{i} |w| {rate:.2f} rad/s" if i == 40
                    else f"f{i} |w| {rate:.2f} ssim {infos[i]['ssim']:.2f}")
            cells.append(label(cell, text))
        rows.append(np.hstack(cells))
    ok, png = cv2.imencode(".png", np.vstack(rows)[..., ::-1])
    if not ok:
        raise OSError(f"cannot encode {args.out}")
    text = png_text(command(args.out, args.seed), {"scenarios": list(shown), "frames": shown,
                                                   "seed": args.seed})
    with atomic_output(args.out) as tmp:  # the temporary name keeps the .png suffix
        tmp.write_bytes(add_text(png.tobytes(), text))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
