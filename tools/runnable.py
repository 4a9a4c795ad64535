"""Runnable examples in Markdown: the blocks a reader can paste are the blocks we run.

A fenced `sh` block preceded by the comment `<!-- run -->` is runnable: its text is run
with bash (-e -u -o pipefail) in the page's working directory, one block after the other,
so a later block sees the files an earlier one wrote. A fenced block preceded by
`<!-- output -->` (optionally `<!-- output grep=REGEX -->` or `<!-- output head=N -->`)
is replaced by what the previous runnable block printed on stdout, so a figure quoted in
a page comes from the run, not from a hand. Used by the docs build (tools/mkdocs_hooks.py)
and by tests/test_docs.py for the README.

A block's `lathe-mirror` lines of the plain form (`lathe-mirror WORDS`, its stdout
optionally cut by `| head -N` or `| tail -N` and sent to a file or /dev/null by `> PATH`)
run in this process, by the command line's own entry point (cli.main, as the tests'
run_cli does): the same stdout, files and exit status without a new interpreter's start-up
and imports (0.5-1 s a command, 3 s more for `cad`'s CAD kernel), which the docs' ~40
commands would each pay. The block's other commands (a heredoc, an argument quoted over
several lines, a line continued by a backslash: each kept whole) run in bash between
them, in the block's order, each run of them in one bash; a block with a command that
leaves state for the next (cd, export, an assignment, source) runs in bash from that
command on, as the state would not carry from one bash to the next. LATHE_MIRROR_TEST_FRESH=1 runs every line
in bash (a process each, as a reader does).
"""

from __future__ import annotations

import contextlib
import io
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


#: A plain command line run in this process: words without quotes, variables or globs; its
#: stdout optionally through head or tail, then optionally to a file.
_PLAIN = re.compile(r"lathe-mirror(?P<args>(?:[ \t]+[\w./:=+,@%-]+)+)[ \t]*"
                    r"(?:\|[ \t]*(?P<cut>head|tail)[ \t]+-(?P<n>\d+)[ \t]*)?"
                    r"(?:>[ \t]*(?P<to>[\w./-]+)[ \t]*)?(?:#.*)?")


def run_block(block: Block, cwd: Path, where: str, timeout: float = 900) -> str:
    """Run one runnable block; its stdout, or ExampleFailed naming the page and command."""
    commands = _commands(block.body)
    stdout, shell = [], []
    fresh = os.environ.get("LATHE_MIRROR_TEST_FRESH", "") not in ("", "0")
    for k, command in enumerate(commands):
        m = None if fresh else _PLAIN.fullmatch(command.strip())
        if m is None and _STATEFUL.match(command):  # the rest in one bash, as written
            shell += commands[k:]
            break
        if m is None:
            shell.append(command)
            continue
        stdout.append(_bash(shell, cwd, where, timeout))
        shell = []
        stdout.append(_in_process(m, cwd, where))
    stdout.append(_bash(shell, cwd, where, timeout))
    return "".join(stdout)


def _bash(commands: list[str], cwd: Path, where: str, timeout: float) -> str:
    """Run commands in one bash (-e -u -o pipefail); its stdout ("" for none to run)."""
    if not any(c.strip() for c in commands):
        return ""
    rest = "\n".join(commands)
    proc = subprocess.run(["bash", "-euo", "pipefail", "-c", rest], cwd=cwd,
                          env=environment(), capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        raise ExampleFailed(f"{where}: example exited {proc.returncode}:\n{rest}\n"
                            f"--- stderr ---\n{proc.stderr[-3000:]}")
    return proc.stdout


#: A command that leaves state for the commands after it in the same shell.
_STATEFUL = re.compile(r"\s*(?:cd|pushd|popd|export|source|\.|set|alias|unset|declare|[A-Za-z_]\w*=)(?:\s|$|(?<==))")
_HEREDOC = re.compile(r"<<-?[ \t]*(['\"]?)(\w+)\1")


def _commands(body: str) -> list[str]:
    """A block's lines grouped into the commands bash reads: a heredoc's lines with the
    line that opens it, the lines of an argument quoted over several lines together, and a
    line ending in `\\` with the next."""
    out: list[str] = []
    current: list[str] = []
    quote = ""          # the open quote character carried to the next line, if any
    ends: list[str] = []  # the terminators of the heredocs still open
    for line in body.splitlines():
        current.append(line)
        if ends:
            if (line.lstrip("\t") if ends[0][0] == "-" else line) == ends[0][1:]:
                ends.pop(0)
        else:
            quote, opened = _scan(line, quote)
            ends += opened
        if not ends and not quote and not line.endswith("\\"):
            out.append("\n".join(current))
            current = []
    if current:
        out.append("\n".join(current))
    return out


def _scan(line: str, quote: str) -> tuple[str, list[str]]:
    """Read one line as bash does for quoting: the quote still open at its end and the
    heredocs it opens ("-TAG" for <<-, " TAG" for <<), outside quotes and comments."""
    opened, i, word_start = [], 0, True
    while i < len(line):
        c = line[i]
        if quote == "'":
            quote = "" if c == "'" else quote
        elif quote == '"':
            if c == "\\":
                i += 1
            elif c == '"':
                quote = ""
        elif c == "\\":
            i += 1
        elif c in "'\"":
            quote = c
        elif c == "#" and word_start:
            break
        elif c == "<" and not line.startswith("<<<", i) and (h := _HEREDOC.match(line, i)):
            opened.append(("-" if line[i + 2] == "-" else " ") + h.group(2))
            i = h.end()
            word_start = False
            continue
        word_start = c in " \t;|&()"
        i += 1
    return quote, opened


def _in_process(m: re.Match, cwd: Path, where: str) -> str:
    """One _PLAIN line by cli.main in cwd: what it leaves on stdout (cut, or sent to its file)."""
    from lathe_mirror.cli import main

    out, err = (io.TextIOWrapper(io.BytesIO(), encoding="utf-8", newline="") for _ in range(2))
    old = os.getcwd()
    try:
        os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(m["args"].split())
            except SystemExit as exc:  # argparse: a usage error
                status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        os.chdir(old)
    out.flush()
    err.flush()
    text = out.buffer.getvalue().decode("utf-8")
    if status != 0:
        raise ExampleFailed(f"{where}: example exited {status}:\n{m.group(0)}\n"
                            f"--- stderr ---\n{err.buffer.getvalue().decode('utf-8')[-3000:]}")
    if m["cut"]:
        kept = text.splitlines(keepends=True)
        text = "".join(kept[:int(m["n"])] if m["cut"] == "head" else kept[len(kept) - int(m["n"]):])
    if m["to"]:
        if m["to"] != "/dev/null":
            (cwd / m["to"]).write_text(text, encoding="utf-8")
        return ""
    return text


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
