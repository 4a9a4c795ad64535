"""Options and output shared by every subcommand."""

from __future__ import annotations

import argparse
import sys
from typing import Any


def add_common(parser: argparse.ArgumentParser, *, output_help: str | None = None) -> None:
    """--config FILE, -o/--output, --json: the options every stage takes."""
    parser.add_argument("--config", metavar="FILE",
                        help="TOML file merged over the paper default (any part of it)")
    parser.add_argument("-o", "--output", metavar="PATH",
                        help=output_help or "where to write the stage's files")
    parser.add_argument("--json", action="store_true",
                        help="print the stage's figures as JSON on stdout")


def load(args: argparse.Namespace) -> dict[str, Any]:
    """The validated configuration for a command (defaults + --config)."""
    from ..config import load_config

    return load_config(args.config)


def print_json(data: Any) -> None:
    """JSON on stdout: finite numbers only (NaN/inf become null)."""
    from ..export.files import json_text

    sys.stdout.write(json_text(data))
