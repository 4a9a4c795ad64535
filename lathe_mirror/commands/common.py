"""Options and output shared by every subcommand."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from collections.abc import Callable
from typing import Any


def add_common(parser: argparse.ArgumentParser, *, output_help: str | None = None) -> None:
    """--config FILE, -o/--output, --json: the options every stage takes."""
    parser.add_argument("--config", metavar="FILE",
                        help="TOML file merged over the paper default (any part of it)")
    parser.add_argument("-o", "--output", metavar="PATH", type=path_arg,
                        help=output_help or "where to write the stage's files")
    parser.add_argument("--json", action="store_true",
                        help="print the stage's figures as JSON on stdout")


def add_no_progress(parser: argparse.ArgumentParser) -> None:
    """--no-progress: no progress display on stderr (the stages that take seconds)."""
    parser.add_argument("--no-progress", action="store_true", help="no progress display on stderr")


def add_compute(parser: argparse.ArgumentParser, what: str = "the Monte Carlo trials") -> None:
    """--workers N and --scheduler ADDRESS: where the heavy trials run (lathe_mirror.compute)."""
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help=f"processes for {what} (default [compute] workers: all cores; 1 runs them "
                        "in this process); the same seed gives the same result with any number")
    parser.add_argument("--scheduler", metavar="ADDRESS", default=None,
                        help=f"run {what} on the Dask cluster at this scheduler address (tcp://HOST:PORT; "
                        "default [compute] scheduler)")


def compute_options(args: argparse.Namespace, settings=None) -> tuple[int | None, str | None]:
    """(workers, scheduler) from the flags, else the settings' [compute] (workers 0 or
    None: all cores; scheduler "" or None: local processes), checked: call it with the
    flags alone before any work, and again with the settings."""
    from ..compute import check_scheduler, check_workers

    cfg = getattr(settings, "compute", None)
    workers = getattr(args, "workers", None)
    scheduler = getattr(args, "scheduler", None)
    if workers is not None:
        check_workers(workers)
    if scheduler is not None:
        check_scheduler(scheduler)
    if workers is None:
        workers = getattr(cfg, "workers", None)
    if scheduler is None:
        scheduler = getattr(cfg, "scheduler", None)
    return workers or None, scheduler or None


def compute_session(args: argparse.Namespace, settings=None):
    """The command's executor, active for the block (lathe_mirror.compute.session)."""
    from ..compute import session

    return session(*compute_options(args, settings))


def use_compute(args: argparse.Namespace, settings=None):
    """The command's executor, active until the command ends (cli.main shuts it down)."""
    from ..compute import activate

    return activate(*compute_options(args, settings))


def load(args: argparse.Namespace, overrides: list[tuple[str, Any, str]] | None = None):
    """The command's Settings (defaults + --config + flag overrides (key, value, flag),
    --workers and --scheduler among them), validated once before any work; the cost
    estimates count the Monte Carlo runs of args.command (settings.costs.planned)."""
    from ..config import load as load_settings
    from ..settings.costs import planned

    overrides = [*(overrides or ()), ("compute.workers", getattr(args, "workers", None), "--workers"),
                 ("compute.scheduler", getattr(args, "scheduler", None), "--scheduler")]
    # the cost estimates count the Monte Carlo runs this command makes, on its executor
    with planned(getattr(args, "command", None), allocate=bool(getattr(args, "allocate", False))):
        return load_settings(args.config, overrides=[o for o in overrides if o[1] is not None])


def load_on_executor(args: argparse.Namespace, overrides: list[tuple[str, Any, str]] | None = None):
    """The command's Settings (load) for a command that runs trials: --workers and
    --scheduler checked before any work, then the executor they and [compute] name made
    active until the command ends (use_compute)."""
    compute_options(args)  # the flags, before any work
    settings = load(args, overrides)
    use_compute(args, settings)
    return settings


def print_json(data: Any) -> None:
    """JSON on stdout: finite numbers only (NaN/inf become null)."""
    from ..export.files import json_text

    sys.stdout.write(json_text(data))


def print_result(args: argparse.Namespace, data: Any, text: Callable[[Any], str]) -> None:
    """The command's figures on stdout: JSON with --json (print_json), else `text(data)`."""
    if args.json:
        print_json(data)
    else:
        print(text(data))


def output_dir(path: str | Path, what: str = "-o/--output") -> Path:
    """Create an output directory (and parents): export.files.prepare_dir, which removes
    the ones it made again if the command then fails."""
    from ..export.files import prepare_dir

    return prepare_dir(path, what)


def check_outputs(directory: str | Path | None, names: list[str], what: str = "-o/--output") -> list[Path]:
    """Check, before any work, that every file a command will write can be written:
    `names` inside `directory` (made by the command if missing), or paths of their own
    with directory None. Returns the paths."""
    from ..export.files import check_output_dir, check_target

    if directory is None:
        return [check_target(n, what) for n in names]
    d = check_output_dir(directory, what)
    out = []
    for n in names:
        check_target(d / n, what, parent_made=True)
        out.append(d / n)
    return out


def path_arg(text: str) -> str:
    """-o's (and every output flag's) argparse type: a non-empty path (an empty one would fall back to the default
    name silently)."""
    if not text:
        raise argparse.ArgumentTypeError("empty path: name a file or directory")
    return text


def program_strategy(value: str | None, settings):
    """--program paper|best as the Strategy a part was cut with (None: [toolpath] strategy)."""
    from ..enums import Program, parse

    if value is None:
        return settings.toolpath.strategy
    return parse(Program, value, "--program").strategy


def surface_arg(text: str | None, flag: str = "--surface"):
    """--surface NAME or measured:FILE as (enums.Surface or None, the measured file or None)."""
    from ..enums import Surface, parse

    if text is None:
        return None, None
    if text.lower().startswith("measured:"):
        path = text.split(":", 1)[1]
        if not path:
            from ..errors import InputError

            raise InputError(f"{flag} measured: name the measured file, measured:FILE")
        return Surface.MEASURED, path
    surface = parse(Surface, text, flag)
    if surface is Surface.MEASURED:  # the name alone: which file?
        from ..errors import InputError

        raise InputError(f"{flag} {text}: name the measured file, measured:FILE")
    return surface, None
