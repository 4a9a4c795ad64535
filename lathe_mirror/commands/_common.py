"""Options and output shared by every subcommand."""

from __future__ import annotations

import argparse
import json
import math
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
    """JSON on stdout: sorted keys, finite numbers only (NaN/inf become null)."""
    json.dump(_finite(data), sys.stdout, indent=2, sort_keys=False)
    sys.stdout.write("\n")


def _finite(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if hasattr(x, "item") and hasattr(x, "dtype"):  # numpy scalar
        return _finite(x.item())
    return x
