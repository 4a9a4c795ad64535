"""Atomic file writing: a file appears whole under its name, or not at all."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

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
    if path.exists() and not path.is_file():
        # A device, FIFO or socket: the atomic rename would replace it with a regular file.
        raise InputError(f"{what} {path}: is not a regular file (a device, FIFO or socket)")
    if not parent.is_dir():
        raise InputError(f"{what} {path}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"{what} {path}: directory {parent} is not writable")
    return path


def write_bytes(path: str | Path, data: bytes, what: str = "-o/--output") -> Path:
    """Write data to path through a temporary name in the same directory, then rename."""
    path = check_writable(path, what)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent or ".")
    except OSError as exc:
        raise InputError(f"{what} {path}: cannot write ({exc.strerror})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise InputError(f"{what} {path}: cannot write ({exc.strerror})") from None
        raise
    return path


def write_text(path: str | Path, text: str, what: str = "-o/--output") -> Path:
    """write_bytes for UTF-8 text with Unix newlines."""
    return write_bytes(path, text.encode("utf-8"), what)


def json_ready(x: Any) -> Any:
    """A copy of x that json can write: str keys, lists for tuples and numpy arrays, Python
    numbers for numpy scalars, enum values, and null for NaN / inf (JSON has neither)."""
    if isinstance(x, dict):
        return {str(k): json_ready(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_ready(v) for v in x]
    if hasattr(x, "tolist") and hasattr(x, "dtype"):  # numpy array or scalar
        return json_ready(x.tolist())
    if hasattr(x, "value") and not isinstance(x, (int, float, str)):  # enums
        return x.value
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def json_text(data: Any, *, indent: int = 2) -> str:
    """JSON of data (through json_ready), key order kept, ending in a newline."""
    return json.dumps(json_ready(data), indent=indent, allow_nan=False) + "\n"
