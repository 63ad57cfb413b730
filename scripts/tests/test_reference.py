"""`python -m scripts.reference`: the committed reference pages are what the code generates now, a
key the environment returns undescribed stops the generator, the scene pictures show
something, it prints each file it wrote, and a bad --out is refused in one line."""

import io
from pathlib import Path

import numpy as np
import pytest

from scripts.reference import scenarios as reference
from scripts.reference.__main__ import main

DOCS = Path(__file__).resolve().parents[2] / "docs" / "reference"


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[Path, str]:
    """The pages as `python -m scripts.reference --no-pictures` writes them now, and what it
    printed."""
    out = tmp_path_factory.mktemp("reference")
    with pytest.MonkeyPatch.context() as mp:
        printed = io.StringIO()
        mp.setattr("sys.stdout", printed)
        assert main(["--out", str(out), "--no-pictures"]) == 0
    assert not (out / reference.SCENES).exists()  # --no-pictures: none rendered
    return out, printed.getvalue()


@pytest.fixture(scope="module")
def generated(written) -> Path:
    return written[0]


def test_it_prints_each_file_it_wrote(written):
    out, printed = written
    assert printed.splitlines() == [f"wrote {out / 'scenarios.md'}", f"wrote {out / 'cli.md'}"]


def test_committed_scenarios_page_is_current(generated):
    assert (DOCS / "scenarios.md").read_text() == (generated / "scenarios.md").read_text(), (
        "docs/reference/scenarios.md differs from what the code generates (a scenario, a "
        "space, a key or a parameter changed): regenerate it with "
        f"`{reference.REGENERATE}` (add --no-pictures if no scene changed)")


def test_committed_cli_page_is_current(generated):
    # Compared word by word: Python 3.13's argparse wraps usage lines differently.
    committed, now = ((d / "cli.md").read_text().split() for d in (DOCS, generated))
    assert committed == now, (
        "docs/reference/cli.md differs from the commands' --help (a command or an option "
        f"was added or changed): regenerate it with `{reference.REGENERATE} --no-pictures`")


def test_every_scenario_has_its_picture_and_section():
    page = (DOCS / "scenarios.md").read_text()
    for name in reference.packaged():
        assert f"]({reference.SCENES}/{name}.png)" in page
        assert (DOCS / reference.SCENES / f"{name}.png").stat().st_size > 10_000


def test_an_undescribed_info_key_stops_the_generator(monkeypatch):
    from lgmd_sim.world import core

    monkeypatch.delitem(core.TRUTH_KEYS, "threat_ttc")
    with pytest.raises(ValueError, match=r"info key.*threat_ttc.*no description"):
        reference.scenarios_page()


def test_scene_picture_shows_the_scene():
    image = reference.scene_picture("RoughTerrainObstacles", height=48, width=80)
    assert image.shape == (48, 80, 3) and image.dtype == np.uint8
    # not one colour: ground, obstacles, the close-up's frame and the ring all differ
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 50
    assert image[:, :, 0].std() > 10


def test_a_file_as_out_is_refused_in_one_line(tmp_path, capsys):
    out = tmp_path / "page.md"
    out.write_text("mine")
    assert main(["--out", str(out), "--no-pictures"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and str(out) in err
    assert out.read_text() == "mine"
