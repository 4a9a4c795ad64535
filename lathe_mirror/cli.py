"""The `lathe-mirror` command line: parse, call the API, print, set the exit status.

Each subcommand lives in `lathe_mirror.commands.<name>` with `register(subparsers)`;
those modules import nothing heavy at import time, so `--help` and `design` start fast.
Exit status: 0 success, 2 bad input (one line on stderr), 1 internal failure.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback

from .version import __version__
from .errors import InputError

COMMANDS = ("design", "toolpath", "cad", "render", "polish", "tolerance", "calib", "stereo", "report", "run",
            "optimize")


class _Parser(argparse.ArgumentParser):
    """argparse with the one-line error of every other bad input (no usage block)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="lathe-mirror",
        description="Design a double-lobed hyperbolic mirror for an omnidirectional camera, "
        "turn it on a CNC lathe within its limits, and predict what the made mirror does "
        "to the image and to stereo depth.",
    )
    parser.add_argument("--version", action="version", version=f"lathe-mirror {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        modname = f"lathe_mirror.commands.{name}"
        try:
            module = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name == modname:
                continue  # a stage not built yet
            raise
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    from .commands.common import remove_made_dirs

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        remove_made_dirs()  # a failed command leaves no empty output directory behind
        print(f"lathe-mirror {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        remove_made_dirs()
        print("lathe-mirror: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # an internal failure: say so, keep the trace on request
        remove_made_dirs()
        if os.environ.get("LATHE_MIRROR_DEBUG"):
            traceback.print_exc()
        print(
            f"lathe-mirror {args.command}: internal error: {type(exc).__name__}: {exc} "
            "(set LATHE_MIRROR_DEBUG=1 for the traceback)",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":
    sys.exit(main())
