"""Atomic file writing: a file appears whole under its name, or not at all.

Each file is written through a temporary name in its own directory and renamed over the
target. A command (cli.main) writes inside a `staging()` block: every file of the
command is kept in memory until the command has succeeded, then all of them are written
(`commit`); a failure at any point, SIGINT or SIGTERM drops them (`abort`), so a failed
command leaves no file behind and the files it would have replaced keep their old bytes,
and the directories it made are removed again where they are still empty.

Output names are checked before any work (`check_target`, `check_output_dir`): the name
length (NAME_MAX bytes a component), a directory or a device in the file's place, a
missing or unwritable directory. `-o` naming a symbolic link writes the file the link
points to; the link stays a link.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Iterator

from ..errors import InputError

#: Longest file or directory name (bytes) a component of an output path may have.
NAME_MAX = 255
#: The temporary name's prefix keeps at most this much of the target's name (".<name>."
#: plus mkstemp's 8 characters and ".part" stay within NAME_MAX).
_TMP_STEM = 200

# The current command's staged files {target: bytes} (None: write at once), and the
# directories prepare_dir made for it, outermost first.
_staged: dict[Path, bytes] | None = None
_made_dirs: list[Path] = []


@contextlib.contextmanager
def staging() -> Iterator[None]:
    """Keep every file written inside the block in memory; write them all when the block
    ends normally, none (and remove the directories made) when it raises."""
    begin()
    try:
        yield
    except BaseException:
        abort()
        raise
    commit()


def begin() -> None:
    """Start staging (see the module doc)."""
    global _staged
    _staged = {}
    _made_dirs.clear()


def commit() -> list[Path]:
    """Write the staged files (each atomically, in the order written); returns them."""
    global _staged
    staged, _staged = _staged or {}, None
    try:
        out = [_write_now(path, data, "-o/--output") for path, data in staged.items()]
    except BaseException:
        _remove_made_dirs()
        raise
    _made_dirs.clear()
    return out


def abort() -> None:
    """Drop the staged files and remove the directories made for them (if empty)."""
    global _staged
    _staged = None
    _remove_made_dirs()


def written_bytes(path: str | Path) -> bytes:
    """The bytes written to path by this command (staged or already on disk)."""
    target = _target(Path(path))
    if _staged is not None and target in _staged:
        return _staged[target]
    return target.read_bytes()


def prepare_dir(path: str | Path, what: str = "-o/--output") -> Path:
    """Create the output directory (and parents) or raise InputError naming it. The
    directories made are removed again if the command fails (see abort)."""
    path = Path(path)
    check_output_dir(path, what)
    missing = []
    q = path
    while not _lexists(q) and q != q.parent:
        missing.append(q)
        q = q.parent
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{what} {path}: cannot create directory ({exc.strerror})") from None
    _made_dirs.extend(reversed(missing))
    if not os.access(path, os.W_OK):
        raise InputError(f"{what} {path}: directory is not writable")
    return path


def check_output_dir(path: str | Path, what: str = "-o/--output") -> Path:
    """InputError unless path is, or can be made as, a writable directory: every name
    within NAME_MAX, no file in the way, the nearest existing parent a writable directory."""
    path = Path(path)
    if str(path) == "":
        raise InputError(f"{what} '': empty path; name a directory")
    _check_names(path, what)
    q = path
    while not _lexists(q):
        if q == q.parent:
            break
        q = q.parent
    if q.exists() and not q.is_dir():
        where = "is" if q == path else f"has {q} in its way, which is"
        raise InputError(f"{what} {path}: {where} not a directory")
    if not q.exists():  # a dangling symbolic link
        raise InputError(f"{what} {path}: {q} is a broken symbolic link")
    if q != path and not os.access(q, os.W_OK | os.X_OK):
        raise InputError(f"{what} {path}: directory {q} is not writable")
    return path


def check_target(path: str | Path, what: str = "-o/--output", *, parent_made: bool = False) -> Path:
    """InputError unless a regular file can be written at path: its names within NAME_MAX,
    not a directory, device, FIFO or socket, its directory existing and writable (or, with
    parent_made, one check_output_dir allows: the command makes it). Returns the path the
    file will really be written to (a symbolic link's target)."""
    path = Path(path)
    if str(path) == "":
        raise InputError(f"{what} '': empty file name")
    _check_names(path, what)
    target = _target(path)
    if target.is_dir():
        raise InputError(f"{what} {path}: is a directory, expected a file name")
    if target.exists() and not target.is_file():
        # A device, FIFO or socket: the atomic rename would replace it with a regular file.
        raise InputError(f"{what} {path}: is not a regular file (a device, FIFO or socket)")
    parent = target.parent if str(target.parent) else Path(".")
    if parent_made:
        check_output_dir(parent, what)
    elif not parent.is_dir():
        raise InputError(f"{what} {path}: directory {parent} does not exist")
    elif not os.access(parent, os.W_OK):
        raise InputError(f"{what} {path}: directory {parent} is not writable")
    return target


def check_writable(path: str | Path, what: str = "-o/--output") -> Path:
    """check_target for a file whose directory must exist (kept for the writers' use)."""
    return check_target(path, what)


def write_bytes(path: str | Path, data: bytes, what: str = "-o/--output") -> Path:
    """Write data to path through a temporary name in the same directory, then rename
    (inside staging(): keep it until the command succeeds). Returns path."""
    path = Path(path)
    target = check_target(path, what)
    if _staged is not None:
        _staged[target] = bytes(data)
        return path
    _write_now(target, data, what)
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
    """JSON of data (through json_ready), key order kept, ending in a newline; every float
    at its stated precision (export.numbers.json_precise: by the unit suffix of its key,
    `_mm` to 1e-9, `_px` to 1e-6, ..., else 12 significant digits)."""
    from .numbers import json_precise

    return json.dumps(json_precise(json_ready(data)), indent=indent, allow_nan=False) + "\n"


# --------------------------------------------------------------------------------------
# Helpers


def _write_now(target: Path, data: bytes, what: str) -> Path:
    parent = target.parent if str(target.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name[:_TMP_STEM]}.", suffix=".part", dir=parent)
    except OSError as exc:
        raise InputError(f"{what} {target}: cannot write ({exc.strerror})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise InputError(f"{what} {target}: cannot write ({exc.strerror})") from None
        raise
    return target


def _target(path: Path) -> Path:
    """Where a file named path is written: a symbolic link's target (followed through
    every link), else path itself."""
    if path.is_symlink():
        return Path(os.path.realpath(path))
    return path


def _check_names(path: Path, what: str) -> None:
    for part in path.parts:
        n = len(os.fsencode(part))
        if n > NAME_MAX:
            raise InputError(f"{what} {_short(path)}: a name of {n} bytes; allowed at most {NAME_MAX} "
                             "bytes a file or directory name")
    if len(os.fsencode(str(path.absolute()))) > 4000:
        raise InputError(f"{what} {_short(path)}: path longer than 4000 bytes")


def _short(path: Path) -> str:
    s = str(path)
    return s if len(s) <= 60 else s[:28] + "..." + s[-28:]


def _lexists(p: Path) -> bool:
    try:
        return os.path.lexists(p)
    except (OSError, ValueError):
        return False


def _remove_made_dirs() -> None:
    """Remove the directories prepare_dir made, innermost first, where still empty."""
    while _made_dirs:
        d = _made_dirs.pop()
        try:
            d.rmdir()
        except OSError:
            pass
