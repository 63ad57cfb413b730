"""MkDocs hooks (mkdocs.yml `hooks:`): a page reads the same in the site as on GitHub.

Links to repository files that are no page of the site: on GitHub a relative link to
`../../examples/eta_lgmd.py`, to `../CHANGELOG.md` or to a folder of docs/ opens that file
or folder, and tests/docs/test_findings.py reads a finding's numbers from the files it links. So
the Markdown keeps those links, and the site rewrites them: to the file on the repository's
site when mkdocs.yml names a `repo_url`, else to its path as code text (the repository has
no public address yet). A link to a file that does not exist is left alone, for MkDocs'
validation to report and `--strict` to fail on.

Lists: GitHub starts a list right under a paragraph's line; Python-Markdown needs a blank
line before it.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

# At each position: a fenced code block, a link (its text may hold code spans and one level
# of brackets; an image is matched so that it is left alone), or a code span. Whatever
# comes first wins, so a link inside code is code, and code inside a link's text is text;
# a code span ends within its paragraph.
_TOKEN = re.compile(
    r"(?P<fence>^[ \t]*(?P<ticks>`{3,}|~{3,}).*?^[ \t]*(?P=ticks)[ \t]*$)"
    r"|(?P<link>(?P<bang>!?)\[(?P<text>(?:[^\[\]\n]|\[[^\[\]\n]*\])*)\]"
    r"\((?P<target>[^)\s]+)(?P<title>\s+\"[^\"]*\")?\))"
    r"|(?P<code>(?P<bt>`+)(?:(?!\n[ \t]*\n).)+?(?<!`)(?P=bt)(?!`))",
    re.M | re.S,
)
_ITEM = re.compile(r"([-*+]|1[.)])[ \t]")
_FENCE = re.compile(r"[ \t]*(`{3,}|~{3,})")
_SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:|^#|^/")


def rewrite(markdown: str, src_uri: str, docs_dir: Path, root: Path,
            repo_url: str | None) -> str:
    """`markdown` (the page docs_dir/src_uri) with each link to a repository file or folder
    that the site has no page or file for made a link to it on `repo_url`, or code text.
    `root` is the repository (the folder of mkdocs.yml)."""
    docs = docs_dir.resolve().relative_to(root.resolve()).as_posix()

    def one(m: re.Match) -> str:
        if not m.group("link") or m.group("bang"):
            return m.group(0)
        target = m.group("target")
        if _SCHEME.match(target):
            return m.group(0)
        path, _, anchor = target.partition("#")
        inside = posixpath.normpath(posixpath.join(posixpath.dirname(src_uri), path))
        if not inside.startswith("../") and not (docs_dir / inside).is_dir():
            return m.group(0)  # a page or file of the site: MkDocs checks and converts it
        repo_path = posixpath.normpath(posixpath.join(docs, inside))
        if repo_path.startswith("../") or not (root / repo_path).exists():
            return m.group(0)  # outside the repository, or missing: MkDocs reports it
        folder = (root / repo_path).is_dir()
        shown = repo_path + ("/" if folder else "") + (f"#{anchor}" if anchor else "")
        text = m.group("text")
        if repo_url:
            kind = "tree" if folder else "blob"
            return f"[{text}]({repo_url.rstrip('/')}/{kind}/HEAD/{shown})"
        bare = text.strip().strip("`").rstrip("/")
        if bare and (repo_path.endswith(bare) or shown.endswith(bare)):
            return f"`{shown}`"
        return f"{text} (`{shown}`)"

    return _TOKEN.sub(one, markdown)


def lists_interrupt_paragraphs(markdown: str) -> str:
    """A blank line before a list that starts right under a paragraph's line. GitHub (as
    CommonMark) starts the list there; Python-Markdown runs it into the paragraph."""
    out: list[str] = []
    fence = None
    for line in markdown.split("\n"):
        opened = _FENCE.match(line)
        if fence is None and opened:
            fence = opened.group(1)
        elif fence is not None:
            if line.strip() == fence:
                fence = None
        elif (_ITEM.match(line) and out and out[-1].strip() and out[-1][0] not in " \t|"
              and not _ITEM.match(out[-1])):
            out.append("")
        out.append(line)
    return "\n".join(out)


def on_page_markdown(markdown, page, config, files):
    markdown = lists_interrupt_paragraphs(markdown)
    return rewrite(markdown, page.file.src_uri, Path(config.docs_dir),
                   Path(config.config_file_path).parent, config.repo_url)
