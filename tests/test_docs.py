"""The documentation: generated reference pages are current, the site builds with
`mkdocs build --strict` (its examples run during the build, tools/mkdocs_hooks.py), the
README's runnable examples run, and a browser shows the tutorial with its figures."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import require_program

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import reference  # noqa: E402
import runnable  # noqa: E402


def test_command_reference_is_generated_from_the_parser():
    page = (ROOT / "docs" / "reference" / "commands.md").read_text(encoding="utf-8")
    assert page == reference.commands(), "run: python tools/reference.py"
    for name in ("design", "optimize", "toolpath", "cad", "calib", "tolerance", "run"):
        assert f"## `lathe-mirror {name}`" in page


def test_key_reference_is_generated_from_the_declaration():
    page = (ROOT / "docs" / "reference" / "keys.md").read_text(encoding="utf-8")
    assert page == reference.keys(), "run: python tools/reference.py"
    from lathe_mirror.settings import RANGES
    for pattern in RANGES:
        assert f"`{pattern.replace('lobes.*.', 'lobes.')}`" in page


def test_runnable_blocks_are_found_and_outputs_replaced(tmp_path):
    page = ("x\n<!-- run -->\n```sh\necho 41; echo 42\n```\n\n<!-- output grep=2 -->\n"
            "```text\nstale\n```\n\n<!-- run -->\n```sh\necho 43 > f\n```\n<!-- output -->\n```text\n```\n"
            "<!-- run -->\n```sh\ncat f\n```\n<!-- output -->\n```text\n```\n")
    got = runnable.execute(page, tmp_path, "page")
    assert "```text\n42\n```" in got and "stale" not in got and "echo 41" in got
    assert got.endswith("```sh\ncat f\n```\n```text\n43\n```\n")
    assert [b.kind for b in runnable.blocks(page)] == ["run", "output", "run", "output", "run", "output"]


def test_a_plain_command_line_runs_in_process_as_bash_runs_it(tmp_path, monkeypatch):
    """A block's leading plain `lathe-mirror` lines run in this process (tools/runnable.py):
    the same page and the same files as bash running each in a fresh interpreter
    (LATHE_MIRROR_TEST_FRESH=1); a failing one names its line and its error."""
    page = ("<!-- run -->\n```sh\nlathe-mirror design | tail -3\nlathe-mirror design --json > d.json  # figures\n"
            "lathe-mirror design | head -2\nhead -c 1 d.json\n```\n<!-- output -->\n```text\n```\n")
    # Plain lines between bash's (tools/runnable.py splits the block): a heredoc whose body
    # holds a '#' and a quote, an argument quoted over two lines, a comment with a quote.
    page += ("<!-- run -->\n```sh\necho one  # the mirror's\ncat > c.toml <<'TOML'\n[camera]\nf = 6.0  # \"\nTOML\n"
             "python -c \"\nprint('two')\"\nlathe-mirror design --config c.toml | head -1\ntail -1 c.toml\n```\n"
             "<!-- output -->\n```text\n```\n")
    # A variable set before a plain line: from there on the block runs in one bash.
    page += ("<!-- run -->\n```sh\nX=three\nlathe-mirror design | head -1\necho $X\n```\n"
             "<!-- output -->\n```text\n```\n")
    got = {}
    for fresh in ("0", "1"):
        monkeypatch.setenv("LATHE_MIRROR_TEST_FRESH", fresh)
        (tmp_path / fresh).mkdir()
        got[fresh] = (runnable.execute(page, tmp_path / fresh, "page"), (tmp_path / fresh / "d.json").read_text())
    assert got["0"] == got["1"] and got["0"][1].startswith("{")
    shown = re.findall(r"(?s)```text\n(.*?)\n```", got["0"][0])
    assert len(shown[0].splitlines()) == 3 + 2 + 1 and shown[0].endswith("\n{")  # tail -3, head -2, the file's "{"
    lines = shown[1].splitlines()
    assert lines[:2] == ["one", "two"] and lines[3] == 'f = 6.0  # "' and len(lines) == 4
    assert lines[2] == shown[2].splitlines()[0] and shown[2].splitlines()[1:] == ["three"]
    monkeypatch.setenv("LATHE_MIRROR_TEST_FRESH", "0")
    with pytest.raises(runnable.ExampleFailed, match=r"(?s)exited 2:\nlathe-mirror design --config nope.toml\n.*nope"):
        runnable.execute("<!-- run -->\n```sh\nlathe-mirror design --config nope.toml\n```\n", tmp_path, "page")


#: The examples run on fast settings here (fewer trials, a smaller search): a site
#: configuration merged under each example's own --config (config.SITE_CONFIG_VAR).
FAST = {"LATHE_MIRROR_CONFIG": str(ROOT / "tests" / "data" / "docs_fast.toml")}


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """`mkdocs build --strict -d OUT` in this process (mkdocs' own build, as its command line
    calls it): the examples' plain command lines share this process's imports and planned
    programs with the README's (test_readme_examples_run) instead of a new interpreter's.
    Unlike the command line's -q, the warnings reach mkdocs' counter: strict fails on any."""
    import logging

    from mkdocs.commands.build import build
    from mkdocs.config import load_config

    out = tmp_path_factory.mktemp("site")
    logger = logging.getLogger("mkdocs")
    records: list[str] = []
    keep = logging.Handler(logging.WARNING)
    keep.emit = lambda record: records.append(f"{record.levelname}: {record.getMessage()}")
    level, propagate = logger.level, logger.propagate
    with pytest.MonkeyPatch.context() as env:
        for key, value in {**runnable.environment(), **FAST, "NO_MKDOCS_2_WARNING": "1"}.items():
            env.setenv(key, value)
        env.chdir(ROOT)
        logger.setLevel(logging.WARNING)
        logger.propagate = False
        logger.addHandler(keep)
        try:
            cfg = load_config(str(ROOT / "mkdocs.yml"), strict=True, site_dir=str(out))
            cfg.plugins.on_startup(command="build", dirty=False)
            try:
                build(cfg, dirty=False)
            finally:
                cfg.plugins.on_shutdown()
        except Exception as exc:  # mkdocs' Abort (strict), a failing example (PluginError)
            pytest.fail(f"mkdocs build --strict: {exc}\n" + "\n".join(records)[-4000:], pytrace=False)
        finally:
            logger.removeHandler(keep)
            logger.setLevel(level)
            logger.propagate = propagate
    assert not records, records
    return out


def test_site_builds_strict_and_has_every_page(site):
    for page in ("tutorials/paper-mirror", "tutorials/your-camera", "reference/commands",
                 "reference/keys", "reference/api"):
        assert (site / page / "index.html").is_file(), page


def test_tutorial_shows_its_figures_in_a_browser(site, tmp_path):
    chromium = require_program("chromium")
    page = site / "tutorials" / "your-camera" / "index.html"
    proc = subprocess.run([chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
                           "--disable-background-networking", "--disable-component-update",
                           "--disable-sync", "--no-first-run", "--allow-file-access-from-files",
                           f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=30000",
                           "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    imgs = re.findall(r"<img[^>]*>", proc.stdout)
    figures = [tag for tag in imgs if "figures/" in tag]
    assert len(figures) >= 2, imgs
    for tag in figures:
        width = re.search(r'data-decoded="(\d+)"', tag)
        assert width and int(width.group(1)) > 50, tag


def test_readme_examples_run(tmp_path):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert runnable.blocks(readme), "the README marks its examples <!-- run -->"
    import os

    old = {k: os.environ.get(k) for k in FAST}
    os.environ.update(FAST)
    try:
        out = runnable.execute(readme, tmp_path, "README.md")
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    assert out == readme  # the README quotes no output; its examples ran
    for name in ("shop/mirror_arcs.ngc", "spec/mirror_drawing.pdf", "calib/opencv_outer.yaml", "mymirror.toml"):
        assert (tmp_path / name).is_file(), name
