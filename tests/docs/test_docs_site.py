"""The documentation site: docs/ builds with `mkdocs build --strict` (mkdocs.yml), and the
strict build fails on a broken link, a missing anchor, a link to a missing repository file
or a page missing from the nav. Links to repository files that are no page of the site
(scripts/mkdocs_hooks.py) become code text, or links on the repository's site when
mkdocs.yml names one."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "mkdocs.yml"


def _build(config: Path, site: Path) -> subprocess.CompletedProcess:
    # NO_MKDOCS_2_WARNING: Material's banner about MkDocs 2, printed on every build.
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(config),
         "--site-dir", str(site)],
        cwd=config.parent, capture_output=True, text=True, timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})


def _project(tmp_path: Path, pages: dict[str, str], settings: str = "") -> Path:
    """A small site in tmp_path with the repository's mkdocs.yml settings (its validation,
    its hooks) but its own pages and nav; returns its mkdocs.yml."""
    for name, text in pages.items():
        (tmp_path / "docs" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "docs" / name).write_text(text)
    nav = "".join(f"  - {name}\n" for name in pages if name != "unlisted.md")
    config = tmp_path / "mkdocs.yml"
    config.write_text(f"INHERIT: {CONFIG}\ndocs_dir: docs\n"
                      f"hooks:\n  - {ROOT / 'scripts' / 'mkdocs_hooks.py'}\n"
                      f"{settings}nav:\n{nav}")
    return config


def test_the_docs_site_builds_strict(tmp_path):
    done = _build(CONFIG, tmp_path / "site")
    assert done.returncode == 0, done.stderr
    # every nav section's pages are built, the research log's and a run folder's too
    for page in ["index.html", "getting-started/index.html", "guides/own-detector/index.html",
                 "reference/api/index.html", "leaderboard/index.html",
                 "experiments/index.html", "training/runs/eval-shipped/eval/index.html"]:
        assert (tmp_path / "site" / page).is_file(), page
    # a link to a file outside docs/ is its path as code in the site (no repo_url yet)
    guide = (tmp_path / "site" / "guides" / "own-detector" / "index.html").read_text()
    assert "<code>examples/eta_lgmd.py</code>" in guide
    assert 'href="../../../examples/' not in guide


def test_a_broken_link_fails_the_strict_build_and_is_named(tmp_path):
    page = ("# Home\n\n## Here\n\n"
            "[gone](missing-page.md), [anchor](other.md#no-such-heading), "
            "[file](../no_such_file.py), [folder](../no-such-folder), "
            "[fine](other.md#there), [kept](../kept.py)\n")
    (tmp_path / "kept.py").write_text("")
    config = _project(tmp_path, {"index.md": page, "other.md": "# Other\n\n## There\n",
                                 "unlisted.md": "# Not in the nav\n"})
    done = _build(config, tmp_path / "site")
    assert done.returncode != 0
    log = done.stdout + done.stderr
    for named in ["missing-page.md", "#no-such-heading", "../no_such_file.py",
                  "../no-such-folder", "unlisted.md"]:
        assert named in log, f"{named} not named:\n{log}"
    assert "Aborted with 5 warnings in strict mode" in log, log


def test_the_same_site_without_the_broken_links_builds(tmp_path):
    """The failures above are the broken links', not the small project's."""
    (tmp_path / "kept.py").write_text("")
    config = _project(tmp_path, {
        "index.md": "# Home\n\n[fine](other.md#there), [kept](../kept.py)\n",
        "other.md": "# Other\n\n## There\n"})
    done = _build(config, tmp_path / "site")
    assert done.returncode == 0, done.stderr


def test_a_link_to_a_repository_file_is_code_or_a_link_on_the_repository_s_site(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "tool.py").write_text("")
    page = ("# Home\n**Files**\n"
            "- [`src/tool.py`](../src/tool.py)\n"
            "- [the tool](../src/tool.py#L3)\n"
            "- [sources](../src)\n\n"
            "`[not a link](../src/tool.py)`\n")
    config = _project(tmp_path, {"index.md": page})
    assert _build(config, tmp_path / "plain").returncode == 0
    html = (tmp_path / "plain" / "index.html").read_text()
    assert "<li><code>src/tool.py</code></li>" in html  # a list, not the paragraph's text
    assert "<li>the tool (<code>src/tool.py#L3</code>)</li>" in html
    assert "<li>sources (<code>src/</code>)</li>" in html
    assert "<code>[not a link](../src/tool.py)</code>" in html
    assert "href=\"../src" not in html

    config = _project(tmp_path, {"index.md": page},
                      settings="repo_url: https://github.com/example/lgmd-sim\n")
    assert _build(config, tmp_path / "linked").returncode == 0
    html = (tmp_path / "linked" / "index.html").read_text()
    site = "https://github.com/example/lgmd-sim"
    assert f'<a href="{site}/blob/HEAD/src/tool.py"><code>src/tool.py</code></a>' in html
    assert f'<a href="{site}/blob/HEAD/src/tool.py#L3">the tool</a>' in html
    assert f'<a href="{site}/tree/HEAD/src/">sources</a>' in html
