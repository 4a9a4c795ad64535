"""Atomic file writing: a file appears whole under its name, or not at all."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..errors import InputError


def prepare_dir(path: str | Path, what: str = "-o/--output") -> Path:
    """Create the output directory (and parents) or raise InputError naming it."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{what} {path}: cannot create directory ({exc.strerror})") from None
    if not os.access(path, os.W_OK):
        raise InputError(f"{what} {path}: directory is not writable")
    return path


def check_writable(path: str | Path, what: str = "-o/--output") -> Path:
    """Raise InputError unless a file can be created at path (its directory must exist)."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise InputError(f"{what} {path}: is a directory, expected a file name")
    if not parent.is_dir():
        raise InputError(f"{what} {path}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"{what} {path}: directory {parent} is not writable")
    return path


def write_bytes(path: str | Path, data: bytes, what: str = "-o/--output") -> Path:
    """Write data to path through a temporary name in the same directory, then rename."""
    path = check_writable(path, what)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path


def write_text(path: str | Path, text: str, what: str = "-o/--output") -> Path:
    """write_bytes for UTF-8 text with Unix newlines."""
    return write_bytes(path, text.encode("utf-8"), what)
