"""Runnable examples in Markdown: the blocks a reader can paste are the blocks we run.

A fenced `sh` block preceded by the comment `<!-- run -->` is runnable: its text is run
with bash (-e -u -o pipefail) in the page's working directory, one block after the other,
so a later block sees the files an earlier one wrote. A fenced block preceded by
`<!-- output -->` (optionally `<!-- output grep=REGEX -->` or `<!-- output head=N -->`)
is replaced by what the previous runnable block printed on stdout, so a figure quoted in
a page comes from the run, not from a hand. Used by the docs build (tools/mkdocs_hooks.py)
and by tests/test_docs.py for the README.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_BLOCK = re.compile(
    r"<!-- (?P<kind>run|output)(?P<opts>[^>]*?) -->[ \t]*\n(?P<fence>```+)(?P<lang>[^\n]*)\n"
    r"(?P<body>(?:(?!(?P=fence))[^\n]*\n)*)(?P=fence)")


@dataclass(frozen=True)
class Block:
    kind: str          # "run" or "output"
    options: dict
    lang: str
    body: str
    span: tuple[int, int]


def blocks(markdown: str) -> list[Block]:
    """Every `run` and `output` block of a page, in order."""
    out = []
    for m in _BLOCK.finditer(markdown):
        opts = dict(o.split("=", 1) for o in m.group("opts").split() if "=" in o)
        out.append(Block(m.group("kind"), opts, m.group("lang").strip(), (m.group("body") or "").removesuffix("\n"),
                         m.span()))
    return out


class ExampleFailed(RuntimeError):
    pass


def environment() -> dict[str, str]:
    """The environment examples run in: the project's `lathe-mirror` first on PATH."""
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def run_block(block: Block, cwd: Path, where: str, timeout: float = 900) -> str:
    """Run one runnable block; its stdout, or ExampleFailed naming the page and command."""
    proc = subprocess.run(["bash", "-euo", "pipefail", "-c", block.body], cwd=cwd,
                          env=environment(), capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        raise ExampleFailed(f"{where}: example exited {proc.returncode}:\n{block.body}\n"
                            f"--- stderr ---\n{proc.stderr[-3000:]}")
    return proc.stdout


def _shape(stdout: str, options: dict) -> str:
    lines = stdout.rstrip("\n").splitlines()
    if "grep" in options:
        pat = re.compile(options["grep"])
        lines = [ln for ln in lines if pat.search(ln)]
    if "head" in options:
        lines = lines[: int(options["head"])]
    return "\n".join(lines)


def execute(markdown: str, cwd: Path, where: str) -> str:
    """Run a page's runnable blocks in `cwd` and return the page with every output block
    replaced by the real output of the runnable block before it."""
    pieces, last, stdout = [], 0, None
    for block in blocks(markdown):
        start, end = block.span
        if block.kind == "run":
            stdout = run_block(block, cwd, where)
            continue
        if stdout is None:
            raise ExampleFailed(f"{where}: an output block with no runnable block before it")
        fence = "```"
        text = _shape(stdout, block.options)
        pieces += [markdown[last:start], f"{fence}{block.lang}\n{text}\n{fence}"]
        last = end
    pieces.append(markdown[last:])
    return "".join(pieces)
