"""The closed-loop benchmark's figures read right: every cell told apart (colour and
marker, the same in every figure), results that coincide still visible, axes that span the
data."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from lgmd_sim import metrics
from lgmd_sim.bench import figures

#: (controller, model, preset): a run's cells, two of the same model (two shades of one
#: colour before), the straight controller and two detectors that never alarm (their
#: paths and results those of driving straight).
CELLS = [("straight", None, None), ("oracle", None, None),
         ("reactive", "feedback", "paper"), ("reactive", "feedback", "calibrated-image"),
         ("reactive", "lgmd1", "published"), ("reactive", "lgmd2", "published")]
#: the cells whose paths and results equal straight's
BLIND = {"straight", "reactive: feedback/paper", "reactive: feedback/calibrated-image"}
JITTERS = (0.0, 1.0)


def label(controller: str, model: str | None, preset: str | None) -> str:
    return controller + (f": {model}/{preset}" if model else "")


def summary_rows() -> list[dict]:
    rows = []
    for (controller, model, preset), j in itertools.product(CELLS, JITTERS):
        cell = label(controller, model, preset)
        collided = 4 if cell in BLIND else {"oracle": 0}.get(controller, 2)
        rows.append({"scenario": "RoughTerrainObstacles", "jitter": j, "controller": controller,
                     "model": model, "preset": preset, "tag": None, "cell": cell,
                     "collision_rate": collided / 4,
                     "collision_ci": metrics.wilson_interval(collided, 4),
                     "success_rate": (4 - collided) / 4,
                     "success_ci": metrics.wilson_interval(4 - collided, 4),
                     "false_alarms_per_min": 0.0 if cell in BLIND or controller == "oracle"
                     else 30.0 + 40 * j + (model == "lgmd2") * 50})
    return rows


def examples() -> list[dict]:
    """Top views: the blind cells drive straight into the box; the others turn away."""
    t = np.linspace(0, 1, 60)[:, None]
    straight = np.hstack([2.5 * t, 0 * t])
    records = []
    for (controller, model, preset), j in itertools.product(CELLS, JITTERS):
        cell = label(controller, model, preset)
        turn = {"oracle": 1.5, "reactive": -1.0 if model == "lgmd1" else -2.0}.get(controller)
        path = straight if cell in BLIND else np.hstack([4 * t, turn * t ** 2])
        view = {"obstacles": [{"polygon": [[2.6, -0.3], [3.2, -0.3], [3.2, 0.3], [2.6, 0.3]]},
                              {"circle": [5.0, 1.0, 0.25]}],
                "goal": [6.0, 0.0], "path": path.tolist(),
                "collision_frame": 59 if cell in BLIND else None,
                # terrain far wider than what is drawn on it
                "terrain": np.zeros((5, 5)).tolist(), "extent": [-10.0, 20.0, -12.0, 12.0]}
        records.append({"scenario": "RoughTerrainObstacles", "jitter": j, "seed": 1000,
                        "controller": controller, "model": model, "preset": preset,
                        "tag": None, "cell": cell, "top_view": view})
    return records


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """The figures drawn from the rows and examples, by file name (and written)."""
    folder = tmp_path_factory.mktemp("figures")
    made, save = {}, figures._save

    def keep(fig, path):
        save(fig, path)
        made[path.name] = fig

    mp = pytest.MonkeyPatch()
    mp.setattr(figures, "_save", keep)
    try:
        figures.closed_loop(folder, summary_rows(), examples())
    finally:
        mp.undo()
    assert {p.name for p in folder.glob("*.png")} == set(figures.CLOSED_LOOP)
    return made


def legend_entries(fig) -> dict[str, tuple]:
    """Each legend label's (colour, marker), from the figure's legends and its axes'."""
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    out = {}
    for leg in filter(None, legends):
        for handle, text in zip(leg.legend_handles, leg.get_texts(), strict=True):
            out[text.get_text()] = (to_rgb(handle.get_color()), handle.get_marker())
    return out


def lab(colour) -> np.ndarray:
    """CIE L*a*b* (D65) of an sRGB colour: distances there are what the eye tells apart."""
    rgb = np.array(to_rgb(colour))
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                    [0.0193, 0.1192, 0.9505]]) @ linear / np.array([0.9505, 1.0, 1.089])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


CELL_LABELS = [label(*c) for c in CELLS]


@pytest.mark.parametrize("name", ["false_alarms_vs_collisions.png", "trajectories.png"])
def test_every_cell_has_its_own_colour_and_marker(drawn, name):
    entries = legend_entries(drawn[name])
    assert set(CELL_LABELS) <= set(entries)
    for a, b in itertools.combinations(CELL_LABELS, 2):
        (ca, ma), (cb, mb) = entries[a], entries[b]
        assert np.linalg.norm(lab(ca) - lab(cb)) >= 25, f"{a} and {b}: colours alike"
        assert ma != mb, f"{a} and {b}: the same marker {ma!r}"


def test_a_cell_looks_the_same_in_every_figure(drawn):
    a = legend_entries(drawn["false_alarms_vs_collisions.png"])
    b = legend_entries(drawn["trajectories.png"])
    for cell in CELL_LABELS:
        assert a[cell] == b[cell], cell


def drawn_like(ax, colour, kind: str) -> list:
    """The axes' lines of one colour: paths (kind "line") or single markers ("point")."""
    out = []
    for line in ax.get_lines():
        if to_rgb(line.get_color()) != to_rgb(colour):
            continue
        x = np.asarray(line.get_xdata(), float)
        if kind == "point" and x.size == 1 and line.get_marker() not in ("None", "", None):
            out.append(line)
        if kind == "line" and np.isfinite(x).sum() > 1 and line.get_linestyle() != "None":
            out.append(line)
    return out


def order_of(ax, line) -> tuple:
    return (line.get_zorder(), ax.get_lines().index(line))


def assert_nested(ax, colours: list, kind: str, size, margin: float) -> None:
    """Coinciding lines or points, under one another: each wider than the next by
    `margin`, so that every one shows."""
    drawn = [(order_of(ax, ln), size(ln)) for c in colours for ln in drawn_like(ax, c, kind)]
    assert len(drawn) >= len(colours)
    by_colour = []
    for c in colours:
        lines = drawn_like(ax, c, kind)
        by_colour.append((min(order_of(ax, ln) for ln in lines), max(map(size, lines))))
    by_colour.sort()  # from the bottom up
    for (_, under), (_, over) in itertools.pairwise(by_colour):
        assert under >= over + margin, f"{by_colour}: a {kind} hidden under another"


def test_identical_paths_stay_visible(drawn):
    fig = drawn["trajectories.png"]
    colours = {cell: c for cell, (c, _) in legend_entries(fig).items()}
    for ax in (a for a in fig.axes if a.get_lines()):
        assert_nested(ax, [colours[c] for c in BLIND], "line", lambda ln: ln.get_linewidth(),
                      1.0)


def test_identical_results_stay_visible(drawn):
    fig = drawn["false_alarms_vs_collisions.png"]
    colours = {cell: c for cell, (c, _) in legend_entries(fig).items()}
    panels = [a for a in fig.axes if a.get_lines()]
    # each jitter level: the blind cells' points coincide (no alarm, every run collides)
    blind = [colours[c] for c in BLIND]
    if len(panels) == 1:  # one panel for every jitter level
        pytest.fail("the jitter levels share one panel, their points drawn on each other")
    for ax in panels:
        assert_nested(ax, blind, "point", lambda ln: ln.get_markersize(), 3.0)


def test_trajectory_axes_span_the_data_not_the_terrain(drawn):
    fig = drawn["trajectories.png"]
    panels = [a for a in fig.axes if a.get_lines()]
    assert len(panels) == len(JITTERS)
    # the data: paths (x 0..4, y -2..1.5), the box, the circle (y to 1.25), the goal (x 6)
    for ax in panels:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert -1.0 <= x0 <= 0 and 6.0 <= x1 <= 7.0, (x0, x1)
        assert -3.0 <= y0 <= -2.0 and 1.5 <= y1 <= 2.5, (y0, y1)


def test_error_bars_of_equal_rates_stand_side_by_side(drawn):
    """At each jitter level every cell's point (and its error bar) has an x of its own,
    close to the level: equal rates with equal intervals cannot hide each other."""
    ax = drawn["collisions_vs_jitter.png"].axes[0]
    xs = [x for line in ax.get_lines() if line.get_marker() not in ("", "None", None)
          for x in line.get_xdata()]
    levels = sorted(set(JITTERS))
    span = max(1.0, max(levels) - min(levels))
    for level in levels:
        near = [x for x in xs if abs(x - level) < 0.1 * span]
        assert len(near) >= len(CELLS) and len(set(np.round(near, 6))) == len(CELLS), near


def test_trajectories_draw_a_row_of_panels_per_seed(tmp_path, monkeypatch):
    made, save = {}, figures._save
    monkeypatch.setattr(figures, "_save", lambda fig, path: (save(fig, path),
                                                             made.__setitem__(path.name, fig)))
    two_seeds = examples() + [{**r, "seed": 1001} for r in examples()]
    figures.closed_loop(tmp_path, summary_rows(), two_seeds)
    titles = sorted(a.get_title() for a in made["trajectories.png"].axes if a.get_lines())
    assert titles == sorted(f"RoughTerrainObstacles, jitter {j:g}, seed {s}"
                            for s in (1000, 1001) for j in JITTERS)
