"""MkDocs hooks: the docs are built from the tool itself.

* Runnable examples (tools/runnable.py) of every page are run at build time in a scratch
  directory per page; the outputs quoted in the page are what those runs printed.
* `![caption](run:PATH)` shows a file the page's runs wrote (a figure the tool drew): it
  is copied into the site under figures/<page>/ and the link rewritten to it.
A failing example fails the build (and so `mkdocs build --strict` in the tests).
"""

from __future__ import annotations

import re
import shutil
import sys
import tempfile
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

sys.path.insert(0, str(Path(__file__).resolve().parent))
import runnable  # noqa: E402

_SCRATCH: Path | None = None
_RUN_LINK = re.compile(r"\]\(run:(?P<path>[^)\s]+)\)")


def on_pre_build(config, **kwargs):
    global _SCRATCH
    _SCRATCH = Path(tempfile.mkdtemp(prefix="lathe-mirror-docs-"))


def on_page_markdown(markdown, page, config, files, **kwargs):
    if "<!-- run" not in markdown and "](run:" not in markdown:
        return markdown
    slug = page.file.src_uri.rsplit(".", 1)[0].replace("/", "-")
    cwd = _SCRATCH / slug
    cwd.mkdir(parents=True, exist_ok=True)
    try:
        markdown = runnable.execute(markdown, cwd, page.file.src_uri)
    except runnable.ExampleFailed as exc:
        raise PluginError(str(exc)) from None

    depth = page.file.src_uri.count("/")

    def link(m: re.Match) -> str:
        src = cwd / m.group("path")
        if not src.is_file():
            raise PluginError(f"{page.file.src_uri}: run:{m.group('path')} was not written "
                              "by the page's examples")
        uri = f"figures/{slug}/{src.name}"
        files.append(File.generated(config, uri, abs_src_path=str(src)))
        return "](" + "../" * depth + uri + ")"

    return _RUN_LINK.sub(link, markdown)


def on_post_build(config, **kwargs):
    if _SCRATCH is not None:
        shutil.rmtree(_SCRATCH, ignore_errors=True)
