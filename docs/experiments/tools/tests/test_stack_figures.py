"""docs/experiments/tools/stack_figures.py: a set of figures a page shows together is one
PNG, the parts' pixels one above the other in their order; the open-loop section and the
robot's section write their sets so, and the pages show the stacked figures. Fast: small
made-up PNGs, no run."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[4]
DOCS = ROOT / "docs"
TOOLS = DOCS / "experiments" / "tools"  # the research log's scripts
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+\.png)\)")


def _png(path: Path, image: np.ndarray) -> Path:
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), image)
    return path


def _read(path: Path) -> np.ndarray:
    import cv2

    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def _assert_stacked(sheet: np.ndarray, parts: list[np.ndarray]) -> None:
    """`sheet` is `parts` (BGR) one above the other in order, each padded white on its
    right to the widest."""
    assert sheet.shape == (sum(p.shape[0] for p in parts), max(p.shape[1] for p in parts), 3)
    top = 0
    for part in parts:
        height, width = part.shape[:2]
        assert np.array_equal(sheet[top:top + height, :width], part)
        assert (sheet[top:top + height, width:] == 255).all()
        top += height


def test_the_stacked_figure_is_its_parts_pixels_in_order_a_narrower_one_padded_white(
        tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    stack = importlib.import_module("stack_figures")
    rng = np.random.default_rng(0)
    colour = rng.integers(0, 256, (3, 5, 3), np.uint8)
    grey = rng.integers(0, 256, (2, 4), np.uint8)
    opaque = np.dstack([rng.integers(0, 256, (4, 6, 3), np.uint8), np.full((4, 6), 255,
                                                                         np.uint8)])
    clear = np.zeros((1, 6, 4), np.uint8)  # fully transparent: white on the page
    parts = [_png(tmp_path / f"{name}.png", image) for name, image in
             (("colour", colour), ("grey", grey), ("opaque", opaque), ("clear", clear))]
    out = tmp_path / "written"  # as write_files gives it: no suffix
    stack.stacked(parts)(out)
    _assert_stacked(_read(out), [colour, np.dstack([grey] * 3), opaque[..., :3],
                                 np.full((1, 6, 3), 255, np.uint8)])
    stack.stacked(parts[::-1])(out)  # in the order given
    assert np.array_equal(_read(out)[:1], np.full((1, 6, 3), 255, np.uint8))
    (tmp_path / "none.png").write_bytes(b"not a png")
    with pytest.raises(SystemExit, match="no PNG"):
        stack.stacked([tmp_path / "none.png"])(out)


def test_the_command_writes_the_stacked_figure_of_committed_parts(tmp_path, monkeypatch,
                                                                  capsys):
    monkeypatch.syspath_prepend(str(TOOLS))
    stack = importlib.import_module("stack_figures")
    rng = np.random.default_rng(1)
    images = [rng.integers(0, 256, (h, w, 3), np.uint8) for h, w in ((2, 3), (3, 3), (1, 2))]
    parts = [_png(tmp_path / f"part_{k}.png", im) for k, im in enumerate(images)]
    out = tmp_path / "set.png"
    stack.main([str(out), *map(str, parts)])
    _assert_stacked(_read(out), images)
    assert "wrote" in capsys.readouterr().out
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary
    with pytest.raises(SystemExit):
        stack.main([str(parts[0]), str(parts[0]), str(parts[1])])  # a part overwritten
    with pytest.raises(SystemExit):
        stack.main([str(out), str(tmp_path / "missing.png")])


def test_the_robot_section_shows_a_scenario_s_encounter_maps_as_one_figure_by_jitter(
        tmp_path, monkeypatch):
    """The closed-loop run's encounter maps (one a jitter level) are one file of the
    repository, a panel a jitter level from the lowest (j10 after j2, not after j1); its
    other figures are copied as they are, and the links stand in the order of their names."""
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("robot_page")
    run = tmp_path / "closed-loop-robot"
    rng = np.random.default_rng(2)
    maps = {}
    for jitter, (height, width) in (("0", (2, 4)), ("0.5", (3, 4)), ("1", (2, 3)),
                                    ("10", (1, 4)), ("2", (2, 4))):
        maps[jitter] = rng.integers(0, 256, (height, width, 3), np.uint8)
        _png(run / f"encounters_ArenaRoam_j{jitter}.png", maps[jitter])
    _png(run / "encounters_Other_j1.png", maps["1"])
    for name in ("arena_vs_jitter.png", "trajectories.png"):
        _png(run / name, np.zeros((1, 1, 3), np.uint8))
    figures = {}
    links = page.run_figures(run, figures)
    folder = page.FIGURES / "closed-loop-robot"
    assert links == [f"../results/closed-loop-robot/{name}" for name in (
        "arena_vs_jitter.png", "encounters_ArenaRoam.png", "encounters_Other.png",
        "trajectories.png")]
    for link in links:
        assert (page.OUT.parent / link).resolve() == folder / Path(link).name
    assert figures[folder / "arena_vs_jitter.png"] == run / "arena_vs_jitter.png"
    assert set(figures) == {folder / Path(link).name for link in links}
    out = tmp_path / "written"
    page._copier(figures[folder / "encounters_ArenaRoam.png"])(out)
    _assert_stacked(_read(out), [maps[j] for j in ("0", "0.5", "1", "2", "10")])


def test_the_open_loop_section_shows_its_clips_curves_and_noise_as_one_figure(
        tmp_path, monkeypatch):
    """The open-loop run's clips (by name), detection curves and noise figure, which the page
    shows together, are one file of the repository, in that order; the noise figure only
    where the run has one."""
    monkeypatch.syspath_prepend(str(TOOLS))
    page = importlib.import_module("results_page")
    rng = np.random.default_rng(3)
    run = tmp_path / "open-loop"
    images = {}
    for name, (height, width) in (("clip_B_j0.png", (2, 3)), ("clip_A_j1.png", (1, 3)),
                                  ("noise.png", (2, 2)), ("detection_curves.png", (3, 4))):
        images[name] = rng.integers(0, 256, (height, width, 3), np.uint8)
        _png(run / name, images[name])
    monkeypatch.setattr(page, "_rows", lambda path: [])
    monkeypatch.setattr(page, "_record", lambda run: {"config": {"window": 1, "horizon": 1}})
    monkeypatch.setattr(page, "_command", lambda run: "lgmd-sim bench open-loop")
    monkeypatch.setattr(page, "_paper_sentences", lambda rows: [])
    (run / "summary.md").write_text("| table |")
    figures = {}
    lines = page.open_loop_section(run, figures)
    target = page.FIGURES / "open-loop" / "figures.png"
    assert list(figures) == [target]
    link = "../results/open-loop/figures.png"
    assert (page.OUT.parent / link).resolve() == target
    assert [line for line in lines if line.startswith("![")] == [f"![{link}]({link})"]
    out = tmp_path / "written"
    page._copier(figures[target])(out)
    _assert_stacked(_read(out), [images[n] for n in (
        "clip_A_j1.png", "clip_B_j0.png", "detection_curves.png", "noise.png")])
    (run / "noise.png").unlink()
    figures.clear()
    page.open_loop_section(run, figures)
    page._copier(figures[target])(out)
    assert _read(out).shape == (6, 4, 3)


#: The sets stacked: the page, the figure it shows, and the figures it showed before.
STACKED = [
    ("experiments/results-log.md", "results/open-loop/figures.png",
     [f"results/open-loop/{name}.png" for name in ("clips", "detection_curves", "noise")]),
    ("experiments/results-log.md", "results/closed-loop-robot/encounters_ArenaRoam.png",
     [f"results/closed-loop-robot/encounters_ArenaRoam_j{j}.png" for j in range(3)]),
    ("experiments/figures.md", "experiments/figures/before_after.png",
     [f"experiments/figures/before_after_{name}.png" for name in (
         "collisions_vs_jitter", "encounters_ArenaRoam_j1", "trajectories")]),
]


@pytest.mark.parametrize(("page", "figure", "parts"), STACKED, ids=[s[0] for s in STACKED])
def test_the_pages_show_the_stacked_figure_in_place_of_its_parts(page, figure, parts):
    import cv2

    path = DOCS / page
    shown = {(path.parent / link).resolve() for link in IMAGE.findall(path.read_text())}
    assert (DOCS / figure).resolve() in shown
    assert not shown & {(DOCS / p).resolve() for p in parts}
    assert not [p for p in parts if (DOCS / p).exists()], "a part left beside its set"
    sheet = cv2.imread(str(DOCS / figure))
    assert sheet is not None and sheet.shape[0] > sheet.shape[1] * 2  # three figures
