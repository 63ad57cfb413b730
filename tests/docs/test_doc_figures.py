"""The figures the docs show are what their documented commands make today, and read
right: each PNG records the command and the configuration that made it
(`lgmd_sim.core.pngtext`), checked here against the pages and today's defaults, so that a
default changed without the figures made again fails; the detection figure has a panel per
model, the calibration figure a y axis, the palette reads on white, the contact sheet a row
per scenario and no frame after a collision. Fast: no episode runs."""

from __future__ import annotations

import importlib
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from lgmd_sim import cli, models
from lgmd_sim.apps import demo
from lgmd_sim.cli import demo as demo_cli
from lgmd_sim.core.plots import MIN_CONTRAST, contrast, figure, model_style, palette
from lgmd_sim.core.pngtext import add_text, png_text, read_config, read_text
from lgmd_sim.signals import stimuli

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
TOOLS = DOCS / "experiments" / "tools"  # the research log's scripts
#: Markdown images: (alt text, path).
IMAGE = re.compile(r"!\[([^\]]*)\]\(([^)\s]+\.png)\)")


def test_the_text_chunks_round_trip_through_matplotlib_and_an_encoded_png():
    import cv2

    text = png_text("lgmd-sim demo --out dossier-é", {"seed": 2, "names": ["ü"]})
    ok, encoded = cv2.imencode(".png", np.full((4, 6, 3), 7, np.uint8))
    assert ok
    png = add_text(encoded.tobytes(), {**text, "other": "ω"})  # not Latin-1: iTXt
    assert read_config(png) == ("lgmd-sim demo --out dossier-é", {"seed": 2, "names": ["ü"]})
    assert read_text(png)["other"] == "ω"
    assert np.array_equal(cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR),
                          np.full((4, 6, 3), 7, np.uint8))  # the image as it was
    import io

    fig = figure()
    fig.subplots()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata=text)
    assert read_config(buf.getvalue())[1] == {"seed": 2, "names": ["ü"]}
    assert read_config(encoded.tobytes()) == (None, None)  # none recorded: None


def documented_demo_command() -> str:
    """The command docs/getting-started.md says makes docs/demo."""
    found = re.findall(r"All made by `(lgmd-sim demo [^`]*)`",
                       (DOCS / "getting-started.md").read_text())
    assert len(found) == 1, "docs/getting-started.md names no one command for docs/demo"
    return found[0]


def test_docs_demo_is_what_the_documented_command_makes_with_today_s_defaults():
    """Every figure in docs/demo was made by the documented command, with the episodes it
    runs today (lgmd_sim/apps/defaults.py): a default changed without `lgmd-sim demo --out
    docs/demo` run again fails here."""
    command = documented_demo_command()
    args = cli.build_parser().parse_args(shlex.split(command)[1:])
    assert Path(args.out) == Path("docs/demo")
    today = demo.configuration(**demo_cli.episodes(args))
    assert today["avoider"] is not None  # the closed loop's figure is one of them
    pngs = sorted(p.name for p in (DOCS / "demo").glob("*.png"))
    assert pngs == ["avoid.png", "demo.png", "demo_frame.png"]
    for name in pngs:
        made_by, config = read_config(DOCS / "demo" / name)
        assert made_by == command, f"docs/demo/{name}: made by {made_by!r}, not the docs'"
        assert config == today, f"docs/demo/{name} is of other episodes: run `{command}`"


def test_every_readme_figure_is_captioned_with_the_command_that_made_it():
    readme = (ROOT / "README.md").read_text()
    images = IMAGE.findall(readme)
    assert images, "the README shows no figure"
    for _, path in images:
        command, _ = read_config(ROOT / path)
        assert command, f"{path} does not record the command that made it"
        # the caption names it (a line break may fall inside it)
        assert command in " ".join(readme.split()), f"the README does not name `{command}`"


def test_every_colour_a_detector_s_line_takes_reads_on_white():
    from lgmd_sim.benchmark import figures

    for colour in [*palette(), *figures._EXTRA]:
        assert contrast(colour) >= MIN_CONTRAST, colour
    # every model's line and its calibrated presets' darker shade among them
    for name in models.available():
        for variant in (name, f"{name}/robot"):
            style = model_style(variant)
            a = style.get("alpha", 1.0)
            shown = tuple(a * c + 1 - a for c in to_rgb(style["color"]))
            assert contrast(shown) >= MIN_CONTRAST, variant
    assert contrast("white") == 1.0 and round(contrast("black"), 6) == 21.0


@pytest.fixture(scope="module")
def detection():
    """Every model at its defaults and one at its video preset on a small approach."""
    from lgmd_sim.detect import detect
    from lgmd_sim.detect.specs import with_preset

    clip = stimuli.approaching((60, 80))
    built = {**with_preset(models.available(), None),
             **with_preset(["lgmd1"], "video")}
    return detect(clip.frames, clip.fps, built, clip.collision_frame, name="approach.mp4")


def threshold_lines(ax) -> list:
    """The horizontal lines across a panel (a first alarm's marker is a lone point)."""
    return [ln for ln in ax.get_lines() if len(ln.get_ydata()) == 2
            and len(set(ln.get_ydata())) == 1]


def test_the_detection_figure_has_a_panel_per_model_each_threshold_in_its_colour(detection):
    from lgmd_sim.detect.figure import detection_figure

    fig = detection_figure(detection)
    names = models.available()
    *panels, ssim = fig.axes
    assert [ax.get_title(loc="left") for ax in panels] == names
    assert ssim.get_ylabel() == "SSIM"
    for ax, model in zip(panels, names, strict=True):
        mine = [n for n in detection.models if n.split("/")[0] == model]
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        # its detectors' potentials, no other model's
        assert [lb.split(":")[0] for lb in labels if "alarm at" in lb or "no alarm" in lb
                ] == mine
        colours = {to_rgb(ln.get_color()) for ln in threshold_lines(ax)}
        assert colours == {to_rgb(model_style(n)["color"]) for n in mine}, model
        assert ax.get_ylabel() == "membrane potential"
        assert any(lb.startswith("collision (frame") for lb in labels)  # off the data
        assert not ax.texts or all(t.get_position()[0] > 1.0 for t in ax.texts)
    # a model at two presets stays in one panel; the legends stand beside the panels
    fig.draw_without_rendering()
    for ax in panels:
        assert ax.get_legend().get_window_extent().x0 > ax.get_window_extent().x1


def test_detect_writes_the_per_model_figure_and_records_what_it_ran(detection, tmp_path):
    from lgmd_sim.detect.outputs import write_outputs

    paths = write_outputs(detection, tmp_path, "approach")
    _, config = read_config(paths["png"])
    assert config == {"video": "approach.mp4", "models": list(detection.models),
                      "collision_frame": detection.collision_frame, "noise": None,
                      "noise_seed": None}


def test_the_video_guide_s_detect_figure_is_what_detect_draws_today():
    """docs/detect/handheld.png: every model `lgmd-sim detect` runs by default, on the
    guide's clip, by today's figure code (which records what it ran)."""
    guide = (DOCS / "guides" / "video.md").read_text()
    frame = int(re.search(r"lgmd-sim detect handheld\.mp4 --collision-frame (\d+) "
                          r"--out docs/detect", guide).group(1))
    _, config = read_config(DOCS / "detect" / "handheld.png")
    assert config is not None, "docs/detect/handheld.png: drawn before detect recorded it"
    assert config["models"] == models.available() and config["collision_frame"] == frame


def test_the_findings_detect_figure_is_drawn_by_today_s_code():
    command, config = read_config(DOCS / "video" / "detect.png")
    assert command is not None and "video_page.py --detect-figure-only" in command
    assert config["models"] == [*models.available(),
                                *(f"{m}/video" for m in models.available())]


def calibration_run(name: str):
    from lgmd_sim.calibration.redraw import chosen_of

    return chosen_of(DOCS / "results" / name)


@pytest.mark.parametrize("run", ["calibration-video", "calibration-robot-frames"])
def test_a_calibration_figure_is_redrawn_from_the_run_the_docs_keep(run):
    """chosen_of reads the run as the calibration chose (its summary again, to the
    digit), and calibration_figure labels the y axis of each row."""
    from lgmd_sim.calibration.report import SCORE_LABEL, calibration_figure, summary_markdown

    chosen, objective = calibration_run(run)
    assert summary_markdown(chosen, objective) == (
        DOCS / "results" / run / "summary.md").read_text()
    fig = calibration_figure(chosen, objective)
    shown = [ax for ax in fig.axes if ax.axison]
    rows = {round(ax.get_position().y0, 3) for ax in shown}
    firsts = [min((ax for ax in shown if round(ax.get_position().y0, 3) == y),
                  key=lambda ax: ax.get_position().x0) for y in rows]
    assert len(firsts) == 2 and all(ax.get_ylabel() == SCORE_LABEL for ax in firsts)


#: The calibration figures the docs show: (figure, what the tool draws it from: a run folder
#: the docs keep, or the task of a calibration whose presets the shipped presets file holds).
#: The kept run folders' own calibration.png are no page's figure, and not kept.
CALIBRATION_FIGURES = [
    ("video/calibration.png", "results/calibration-video"),
    ("results/calibration/calibration.png", "walker"),
    ("results/calibration-robot/calibration.png", "robot"),
]


@pytest.mark.parametrize(("png", "source"), CALIBRATION_FIGURES)
def test_the_calibration_figures_of_committed_runs_are_drawn_by_today_s_code(png, source,
                                                                           tmp_path):
    """Each was drawn by docs/experiments/tools/calibration_figure.py from its source (the
    command its PNG records), and drawing it again from today's files with today's code
    gives the same text and pixels: a figure not drawn again after the figure code, the
    run or the shipped presets changed fails. A shipped calibration's figure also has its
    command on docs/findings.md."""
    import cv2

    from lgmd_sim.calibration.redraw import redraw
    from lgmd_sim.calibration.tasks import TASKS
    from lgmd_sim.models.presets import CALIBRATED

    command, config = read_config(DOCS / png)
    tool = "python docs/experiments/tools/calibration_figure.py"
    assert command is not None, f"docs/{png}: run {tool}"
    task = source if source in TASKS else None
    out = [] if Path(png).parent == Path(source) else ["--out", f"docs/{png}"]
    args = ["--task", task, *out] if task else [f"docs/{source}", *out]
    assert command == shlex.join([*shlex.split(tool), *args]), f"docs/{png}: made by {command}"
    redrawn = redraw(CALIBRATED if task else DOCS / source, tmp_path / "calibration.png",
                     command, task)
    assert read_config(redrawn) == (command, config), f"docs/{png}: of another calibration"
    shown, today = (cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in (DOCS / png, redrawn))
    # another matplotlib's anti-aliasing changes edges by a few levels; a missing axis label
    # alone is 8e-4 of the pixels changed by more than 64
    changed = np.mean(np.abs(shown.astype(int) - today) > 64) if shown.shape == today.shape \
        else 1.0
    assert changed < 2e-4, f"docs/{png} is not what today's code draws: run `{command}`"
    if task:
        assert command in (DOCS / "findings.md").read_text()


@pytest.fixture
def contact_sheet(monkeypatch):
    monkeypatch.syspath_prepend(str(TOOLS))
    return importlib.import_module("contact_sheet")


def test_the_contact_sheet_shows_no_frame_after_a_collision(contact_sheet):
    """ArenaRoam goes on after a collision: its frames then show the robot pressed
    against what it hit. The row stops 0.5 s before the first collision."""
    infos = [{"collision": 58 <= i < 900} for i in range(901)]
    shown = contact_sheet.shown_frames(infos, 30.0)
    assert len(shown) == contact_sheet.SHOWN and shown[0] == 0 and shown[-1] == 58 - 15
    assert not any(infos[i]["collision"] for i in shown)
    clear = [{"collision": False}] * 100
    assert contact_sheet.shown_frames(clear, 30.0)[-1] == 99


def test_the_contact_sheet_has_a_row_per_scenario_of_the_catalogue(contact_sheet):
    import cv2

    from lgmd_sim.envs.catalogue import scenarios

    command, config = read_config(DOCS / "contact_sheet.png")
    assert config is not None and config["scenarios"] == list(scenarios())
    concepts = (DOCS / "concepts.md").read_text()
    assert command in " ".join(concepts.split())  # the page names the command
    sheet = cv2.imread(str(DOCS / "contact_sheet.png"))
    width, height = contact_sheet.CELL
    # a row per scenario, then the robot on flat and on rough ground
    assert sheet.shape[:2] == ((len(scenarios()) + 2) * height, contact_sheet.SHOWN * width)
