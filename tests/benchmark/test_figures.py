"""The benchmark's figures read right with many entries (a run of the robot's presets has
19): rates as heatmaps with a row per entry and the values written in, episodes as small
multiples (a panel per entry, one colour), the scatter's points numbered and apart, legends
off the data, and every threshold line tied to its model."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from lgmd_sim.benchmark import figures
from lgmd_sim.core.plots import figure, model_style
from lgmd_sim.detect.figure import draw_thresholds
from lgmd_sim.signals import metrics

#: (controller, model, preset): a run's cells, two of the same model, the straight
#: controller and two detectors that never alarm (their paths and results those of
#: driving straight).
CELLS = [("straight", None, None), ("oracle", None, None),
         ("reactive", "feedback", "paper"), ("reactive", "feedback", "calibrated-image"),
         ("reactive", "lgmd1", "published"), ("reactive", "lgmd2", "published")]
#: the cells whose paths and results equal straight's
BLIND = {"straight", "reactive: feedback/paper", "reactive: feedback/calibrated-image"}
#: Nineteen entries, as the robot's presets make: the baselines and 17 detectors.
MANY = CELLS[:2] + [("reactive", m, p) for m, p in itertools.islice(itertools.product(
    ("feedback", "lgmd1", "lgmd2", "f_on", "f_off"), ("published", "robot", "robot-imu",
                                                      "robot-image")), 17)]
JITTERS = (0.0, 1.0)
SCENARIO = "RoughTerrainObstacles"


def label(controller: str, model: str | None, preset: str | None) -> str:
    return controller + (f": {model}/{preset}" if model else "")


#: Each entry's label in the figures' order (baselines first, then by name), numbered.
ENTRIES = [label(*c) for c in CELLS[:2]] + sorted(label(*c) for c in CELLS[2:])
MANY_ENTRIES = [label(*c) for c in MANY[:2]] + sorted(label(*c) for c in MANY[2:])


def summary_rows(cells=CELLS) -> list[dict]:
    rows = []
    for k, ((controller, model, preset), j) in enumerate(itertools.product(cells, JITTERS)):
        cell = label(controller, model, preset)
        collided = 4 if cell in BLIND else {"oracle": 0}.get(controller, 1 + k % 3)
        rows.append({"scenario": SCENARIO, "jitter": j, "controller": controller,
                     "model": model, "preset": preset, "tag": None, "cell": cell,
                     "task": "goal", "collision_rate": collided / 4,
                     "collision_ci": metrics.wilson_interval(collided, 4),
                     "success_rate": (4 - collided) / 4,
                     "success_ci": metrics.wilson_interval(4 - collided, 4),
                     "false_alarms_per_min": 0.0 if cell in BLIND or controller == "oracle"
                     else 30.0 + 40 * j + (model == "lgmd2") * 50})
    return rows


def examples(cells=CELLS) -> list[dict]:
    """Top views: the blind cells drive straight into the box; the others turn away."""
    t = np.linspace(0, 1, 60)[:, None]
    straight = np.hstack([2.5 * t, 0 * t])
    records = []
    for (controller, model, preset), j in itertools.product(cells, JITTERS):
        cell = label(controller, model, preset)
        turn = {"oracle": 1.5, "reactive": -1.0 if model == "lgmd1" else -2.0}.get(controller)
        path = straight if cell in BLIND else np.hstack([4 * t, turn * t ** 2])
        view = {"obstacles": [{"polygon": [[2.6, -0.3], [3.2, -0.3], [3.2, 0.3], [2.6, 0.3]]},
                              {"circle": [5.0, 1.0, 0.25]}],
                "goal": [6.0, 0.0], "path": path.tolist(),
                "collision_frame": 59 if cell in BLIND else None,
                # terrain far wider than what is drawn on it
                "terrain": np.zeros((5, 5)).tolist(), "extent": [-10.0, 20.0, -12.0, 12.0]}
        records.append({"scenario": SCENARIO, "jitter": j, "seed": 1000,
                        "controller": controller, "model": model, "preset": preset,
                        "tag": None, "cell": cell, "top_view": view})
    return records


def draw(folder, rows, tops, monkeypatch) -> dict:
    """The figures drawn from the rows and top views, by file name (and written)."""
    made, save = {}, figures.save_figure

    def keep(fig, path):
        save(fig, path)
        made[path.name] = fig

    monkeypatch.setattr(figures, "save_figure", keep)
    figures.closed_loop(folder, rows, tops)
    assert {p.name for p in folder.glob("*.png")} == set(made)
    return made


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    try:
        made = draw(tmp_path_factory.mktemp("figures"), summary_rows(), examples(), mp)
    finally:
        mp.undo()
    assert set(made) == set(figures.CLOSED_LOOP)
    return made


@pytest.fixture(scope="module")
def many(tmp_path_factory):
    """The figures of a run of 19 entries (no top views: the rates and the scatter)."""
    mp = pytest.MonkeyPatch()
    try:
        return draw(tmp_path_factory.mktemp("many"), summary_rows(MANY), [], mp)
    finally:
        mp.undo()


def heatmaps(fig) -> list:
    return [ax for ax in fig.axes if ax.get_images() and ax.get_title()]


def written(ax, row: int, column: int) -> list[str]:
    """The texts the heatmap `ax` writes in its cell (row, column)."""
    return [t.get_text() for t in ax.texts
            if abs(t.get_position()[0] - column) < 0.5 and abs(t.get_position()[1] - row) < 0.5]


def test_with_19_entries_the_rates_are_heatmaps_of_a_row_per_entry(many):
    maps = heatmaps(many["collisions_vs_jitter.png"])
    assert [ax.get_title().split("\n")[0] for ax in maps] == [
        f"{SCENARIO}: collision rate", f"{SCENARIO}: success rate"]
    for ax in maps:
        assert ax.get_images()[0].get_array().shape == (19, len(JITTERS))
    assert [t.get_text() for t in maps[0].get_yticklabels()] == [
        f"{cell}  ({k})" for k, cell in enumerate(MANY_ENTRIES, 1)]
    # each cell holds its value and its interval, written
    rows = {(r["cell"], r["jitter"]): r for r in summary_rows(MANY)}
    for ax, (value, ci) in zip(maps, [("collision_rate", "collision_ci"),
                                      ("success_rate", "success_ci")], strict=True):
        for (i, cell), (k, j) in itertools.product(enumerate(MANY_ENTRIES),
                                                   enumerate(JITTERS)):
            r = rows[(cell, j)]
            assert written(ax, i, k) == [f"{r[value]:.2f}",
                                         f"{r[ci][0]:.2f}–{r[ci][1]:.2f}"], (cell, j)


def test_every_heatmap_reads_dark_worse_and_bright_better(drawn):
    """One colormap, one reading: the Oracle (no collision, every goal reached) brightest
    in the collision panel and the success panel alike, the straight controller darkest."""
    collisions, successes = heatmaps(drawn["collisions_vs_jitter.png"])
    for ax in (collisions, successes):
        shown = ax.get_images()[0].get_array()
        assert shown[ENTRIES.index("oracle")].min() == 1.0, ax.get_title()
        assert shown[ENTRIES.index("straight")].max() == 0.0, ax.get_title()
        assert ax.get_images()[0].get_cmap().name.startswith(figures._CMAP)


def test_an_entry_not_run_at_a_level_is_said_so(tmp_path, monkeypatch):
    rows = [r for r in summary_rows() if (r["cell"], r["jitter"]) != ("oracle", 1.0)]
    ax = heatmaps(draw(tmp_path, rows, [], monkeypatch)["collisions_vs_jitter.png"])[0]
    assert written(ax, ENTRIES.index("oracle"), 1) == ["not run"]
    assert np.ma.is_masked(ax.get_images()[0].get_array()[ENTRIES.index("oracle"), 1])


def test_the_scatter_numbers_every_entry_once_per_panel(many):
    fig = many["false_alarms_vs_collisions.png"]
    panels = [ax for ax in fig.axes if ax.get_lines()]
    assert len(panels) == len(JITTERS)
    for ax in panels:
        assert sorted(int(t.get_text()) for t in ax.texts) == list(range(1, 20))
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == [f"{k}  {cell}" for k, cell in enumerate(MANY_ENTRIES, 1)]


def test_the_scatter_colours_an_entry_as_its_model_and_alike_everywhere(many):
    fig = many["false_alarms_vs_collisions.png"]
    legend = {t.get_text().split("  ", 1)[1]: to_rgb(h.get_color())
              for h, t in zip(fig.legends[0].legend_handles, fig.legends[0].get_texts(),
                              strict=True)}
    for ax in (a for a in fig.axes if a.get_lines()):
        discs = {MANY_ENTRIES[int(t.get_text()) - 1]: t.get_position() for t in ax.texts}
        for line in ax.get_lines():
            at = (line.get_xdata()[0], line.get_ydata()[0])
            cell = next(c for c, p in discs.items() if np.allclose(p, at))
            assert to_rgb(line.get_color()) == legend[cell], cell
    # the models apart, and from the baselines
    published = {m: legend[f"reactive: {m}/published"]
                 for m in ("feedback", "lgmd1", "lgmd2", "f_on", "f_off")}
    for a, b in itertools.combinations([*published.values(), legend["oracle"],
                                        legend["straight"]], 2):
        assert np.linalg.norm(lab(a) - lab(b)) >= 25


def test_models_of_other_packages_get_colours_of_their_own(tmp_path, monkeypatch):
    """Two plug-in models (no colour in lgmd_sim.core.plots) apart from each other and from
    every built-in model's colour."""
    cells = [*CELLS, ("reactive", "pkg:A", "default"), ("reactive", "pkg:B", "default")]
    fig = draw(tmp_path, summary_rows(cells), [], monkeypatch)["false_alarms_vs_collisions.png"]
    legend = {t.get_text().split("  ", 1)[1]: to_rgb(h.get_color())
              for h, t in zip(fig.legends[0].legend_handles, fig.legends[0].get_texts(),
                              strict=True)}
    a, b = legend["reactive: pkg:A/default"], legend["reactive: pkg:B/default"]
    assert a != b
    for model in ("feedback", "lgmd1", "lgmd2", "f_on", "f_off"):
        assert to_rgb(model_style(model)["color"]) not in (a, b)


def test_points_that_coincide_stand_apart(drawn):
    """The blind cells' points coincide (no alarm, every run collides): spread around
    their place, no disc covers another's number."""
    fig = drawn["false_alarms_vs_collisions.png"]
    fig.draw_without_rendering()
    blind = {str(ENTRIES.index(c) + 1) for c in BLIND}
    for ax in (a for a in fig.axes if a.get_lines()):
        at = {t.get_text(): ax.transData.transform(t.get_position()) for t in ax.texts}
        width = ax.get_lines()[0].get_markersize() * fig.dpi / 72  # pixels
        for a, b in itertools.combinations(blind, 2):
            assert np.linalg.norm(at[a] - at[b]) >= 0.95 * width, (a, b)


def lab(colour) -> np.ndarray:
    """CIE L*a*b* (D65) of an sRGB colour: distances there are what the eye tells apart."""
    rgb = np.array(to_rgb(colour))
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                    [0.0193, 0.1192, 0.9505]]) @ linear / np.array([0.9505, 1.0, 1.089])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def paths(ax) -> list:
    return [ln for ln in ax.get_lines() if np.isfinite(ln.get_xdata()).sum() > 1]


def test_trajectories_are_small_multiples_of_a_panel_per_entry_in_one_colour(drawn):
    fig = drawn["trajectories.png"]
    grid = np.array(fig.axes).reshape(len(ENTRIES), len(JITTERS))
    assert [ax.get_ylabel() for ax in grid[:, 0]] == [
        f"{cell}  ({k})" for k, cell in enumerate(ENTRIES, 1)]
    colours = set()
    for ax in grid.ravel():
        assert len(paths(ax)) == 1  # one entry's episode
        colours |= {to_rgb(ln.get_color()) for ln in paths(ax)}
    assert len(colours) == 1
    # each blind entry's collision marked where its path ends
    for i in (ENTRIES.index(c) for c in BLIND):
        for ax in grid[i]:
            crosses = [ln for ln in ax.get_lines() if ln.get_marker() == "X"]
            assert [(ln.get_xdata()[0], ln.get_ydata()[0]) for ln in crosses] == [(2.5, 0.0)]


def test_trajectory_axes_span_the_data_not_the_terrain(drawn):
    # the data: paths (x 0..4, y -2..1.5), the box, the circle (y to 1.25), the goal (x 6)
    for ax in drawn["trajectories.png"].axes:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert -1.0 <= x0 <= 0 and 6.0 <= x1 <= 7.0, (x0, x1)
        assert -3.0 <= y0 <= -2.0 and 1.5 <= y1 <= 2.5, (y0, y1)


def test_trajectories_draw_a_column_per_seed_and_jitter_level(tmp_path, monkeypatch):
    two_seeds = examples() + [{**r, "seed": 1001} for r in examples()]
    fig = draw(tmp_path, summary_rows(), two_seeds, monkeypatch)["trajectories.png"]
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == [f"{SCENARIO}\njitter {j:g}, seed {s}" for s in (1000, 1001)
                      for j in JITTERS]


@pytest.mark.slow
def test_nineteen_encounter_maps_fit_a_compact_grid(tmp_path, monkeypatch):
    """A roam run of 19 entries: a panel per entry, at most five across, each path in one
    colour; the figure a page's width and not four of its heights."""
    tops = [{**r, "scenario": "ArenaRoam", "jitter": 0.0,
             "top_view": {**r["top_view"], "goal": None, "encounters": [[1.0, 0.0, True]]}}
            for r in examples(MANY) if r["jitter"] == 0.0]
    rows = [{**r, "scenario": "ArenaRoam", "task": "roam", "success_rate": None,
             "success_ci": None, "avoidance_rate": 1.0, "avoidance_ci": (0.2, 1.0),
             "distance_vs_oracle": 1.0, "collisions_per_min": 1.0}
            for r in summary_rows(MANY)]
    fig = draw(tmp_path, rows, tops, monkeypatch)["encounters_ArenaRoam_j0.png"]
    panels = [ax for ax in fig.axes if ax.get_lines()]
    assert len(panels) == 19
    assert len({round(ax.get_position().x0, 3) for ax in panels}) == 5
    assert fig.get_figwidth() <= 12 and fig.get_figheight() <= 14
    assert len({to_rgb(ln.get_color()) for ax in panels for ln in paths(ax)}) == 1


@pytest.mark.parametrize("name", figures.CLOSED_LOOP)
def test_legends_stand_off_the_data(drawn, name):
    fig = drawn[name]
    fig.draw_without_rendering()
    assert not any(ax.get_legend() for ax in fig.axes)  # no legend inside a panel
    for legend, ax in itertools.product(fig.legends, fig.axes):
        assert not legend.get_window_extent().overlaps(ax.get_window_extent()), ax.get_title()


def threshold_lines(ax) -> list:
    return [ln for ln in ax.get_lines() if len(set(ln.get_ydata())) == 1]


def test_each_threshold_is_drawn_in_its_models_colour_and_named_after_it():
    ax = figure().subplots()
    ax.set_ylim(0.45, 1.02)
    thresholds = {"lgmd1/video": 0.675, "feedback/video": 0.735}
    draw_thresholds(ax, thresholds)
    lines = {ln.get_label(): ln for ln in threshold_lines(ax)}
    assert set(lines) == {f"threshold of {n}: {t:g}" for n, t in thresholds.items()}
    values = {t.get_text(): t for t in ax.texts}
    for name, threshold in thresholds.items():
        colour = to_rgb(model_style(name)["color"])
        line = lines[f"threshold of {name}: {threshold:g}"]
        assert line.get_ydata()[0] == threshold and to_rgb(line.get_color()) == colour
        # its value beside the right edge, outside the data, in the model's colour
        assert to_rgb(values[f"{threshold:g}"].get_color()) == colour
        assert values[f"{threshold:g}"].get_position()[0] > 1.0


def test_a_threshold_shared_by_models_of_two_colours_shows_both():
    ax = figure().subplots()
    draw_thresholds(ax, {"lgmd1": 0.8, "feedback": 0.8})
    lines = threshold_lines(ax)
    assert {to_rgb(ln.get_color()) for ln in lines} == {
        to_rgb(model_style(n)["color"]) for n in ("lgmd1", "feedback")}
    # the dashes alternate: each colour's start where the other's gap is (matplotlib keeps
    # the (offset, dashes) it was given there; no public getter)
    assert len({ln._unscaled_dash_pattern[0] for ln in lines}) == 2
    assert [ln.get_label() for ln in lines if not ln.get_label().startswith("_")] == [
        "threshold of every model: 0.8"]
