"""A set of figures a page shows together, as one PNG: one file of the repository, not one
a figure. The generators of the research log's pages (results_page.py, robot_page.py,
training_page.py) write their sets with `stacked`; a page typed by hand gets its set from
the figures as committed:

    .venv/bin/python docs/experiments/tools/stack_figures.py OUT.png PART.png [PART.png ...]

The parts go one above the other in the order given, each pixel as it is: a narrower one
is padded white on its right, a transparent one laid over white.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from pathlib import Path


def stacked(sources: Sequence[Path]) -> Callable[[Path], None]:
    """What writes `sources` (PNG figures, each with its own title) into one PNG, one
    above the other in their order, a narrower one padded white on its right, their pixels
    as they are: a set of figures a page shows together is one file of the repository."""
    sources = list(sources)

    def write(path: Path) -> None:
        import cv2
        import numpy as np

        panels = []
        for source in sources:
            image = cv2.imread(str(source), cv2.IMREAD_UNCHANGED)
            if image is None:
                raise SystemExit(f"{source}: no PNG")
            if image.ndim == 2:
                image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
            elif image.shape[2] == 4:  # over white
                alpha = image[..., 3:].astype(np.uint32)
                image = ((image[..., :3] * alpha + 255 * (255 - alpha) + 127) // 255
                         ).astype(np.uint8)
            panels.append(image)
        width = max(p.shape[1] for p in panels)
        sheet = np.vstack([np.pad(p, ((0, 0), (0, width - p.shape[1]), (0, 0)),
                                  constant_values=255) for p in panels])
        path.write_bytes(cv2.imencode(".png", sheet, [cv2.IMWRITE_PNG_COMPRESSION, 9])[1]
                         .tobytes())
    return write


def main(argv: Sequence[str] | None = None) -> None:
    from lgmd_sim.core.fileio import write_files

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="the PNG to write")
    parser.add_argument("parts", type=Path, nargs="+", help="the PNGs, top to bottom")
    args = parser.parse_args(argv)
    if args.out.resolve() in {p.resolve() for p in args.parts}:
        parser.error(f"{args.out} is one of the parts")
    missing = [str(p) for p in args.parts if not p.is_file()]
    if missing:
        parser.error(f"missing: {', '.join(missing)}")
    write_files({args.out: stacked(args.parts)})
    print(f"wrote {args.out} ({len(args.parts)} figures)")


if __name__ == "__main__":
    main()
