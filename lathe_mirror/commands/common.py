"""Options and output shared by every subcommand."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

# Directories this process made for its output, outermost first: a command that fails
# after making them leaves nothing behind (cli.main calls remove_made_dirs).
_MADE_DIRS: list[Path] = []


def add_common(parser: argparse.ArgumentParser, *, output_help: str | None = None) -> None:
    """--config FILE, -o/--output, --json: the options every stage takes."""
    parser.add_argument("--config", metavar="FILE",
                        help="TOML file merged over the paper default (any part of it)")
    parser.add_argument("-o", "--output", metavar="PATH",
                        help=output_help or "where to write the stage's files")
    parser.add_argument("--json", action="store_true",
                        help="print the stage's figures as JSON on stdout")


def add_no_progress(parser: argparse.ArgumentParser) -> None:
    """--no-progress: no progress display on stderr (the stages that take seconds)."""
    parser.add_argument("--no-progress", action="store_true", help="no progress display on stderr")


def load(args: argparse.Namespace, overrides: list[tuple[str, Any, str]] | None = None):
    """The command's Settings (defaults + --config + flag overrides (key, value, flag)),
    validated once before any work."""
    from ..config import load as load_settings

    return load_settings(args.config, overrides=[o for o in overrides or () if o[1] is not None])


def print_json(data: Any) -> None:
    """JSON on stdout: finite numbers only (NaN/inf become null)."""
    from ..export.files import json_text

    sys.stdout.write(json_text(data))


def output_dir(path: str | Path, what: str = "-o/--output") -> Path:
    """Create an output directory (and parents) as export.files.prepare_dir does, and
    remember the ones that did not exist, so remove_made_dirs can take them away again
    if the command fails later."""
    from ..export.files import prepare_dir

    path = Path(path)
    missing = []
    q = path
    while not q.exists() and not q.is_symlink() and q != q.parent:
        missing.append(q)
        q = q.parent
    _MADE_DIRS.extend(reversed(missing))
    return prepare_dir(path, what)


def remove_made_dirs() -> None:
    """Remove the directories output_dir made, innermost first, where they are still
    empty (a file a command did write is never removed)."""
    while _MADE_DIRS:
        d = _MADE_DIRS.pop()
        try:
            d.rmdir()
        except OSError:
            pass
