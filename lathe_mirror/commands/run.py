"""`lathe-mirror run`: the whole pipeline on the given or default config."""

from __future__ import annotations

import argparse

from ._common import add_common


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="the whole pipeline (for now: the design)",
                       description="Run every stage on the paper default or --config.")
    add_common(p, output_help="output directory")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from . import design

    return design.run(args)
