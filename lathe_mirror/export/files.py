"""Atomic file writing: a command's files appear whole under their names, all of them, or none.

A command (cli.main) writes inside a `staging()` block: every file of the command is kept
in memory until the command has succeeded, then committed as a set (`commit`): each is
written to a temporary name in its target's directory (and synced), and only when all of
them are written are they renamed over their targets, with the ending signals (SIGINT,
SIGTERM, SIGHUP, SIGQUIT: errors.ENDING_SIGNALS) held off during the renames. A failure
at any point (a full disk, an error, one of those signals)
before the last rename removes the temporaries and puts back any file already replaced
(`abort` drops the staged files), so a failed command leaves no new file and the files it
would have replaced keep their old bytes; the directories it made are removed again where
they are still empty. A signal held off during the renames is delivered after the last one:
then the files stay, and `committed()` tells the command line to exit with success.

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
from .numbers import fmt_sig

#: Longest file or directory name (bytes) a component of an output path may have.
NAME_MAX = 255
#: The temporary name's prefix keeps at most this much of the target's name (".<name>."
#: plus mkstemp's 8 characters and ".part" stay within NAME_MAX).
_TMP_STEM = 200

# The current command's staged files {target: (bytes, the flag that named it)} (None: write
# at once), the directories prepare_dir made for it (outermost first), and whether its
# files have all been renamed into place.
_staged: dict[Path, tuple[bytes, str]] | None = None
_made_dirs: list[Path] = []
_committed = False
# Blocks within which a signal is noted, not acted on (see defer_signal), and the signals noted.
_held = 0
_deferred: list[int] = []


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
    global _staged, _committed
    _staged = {}
    _committed = False
    _made_dirs.clear()


def commit() -> list[Path]:
    """Write the staged files as a set (see the module doc); returns their targets."""
    global _staged, _committed
    staged, _staged = _staged or {}, None
    temps: list[tuple[Path, Path, str]] = []  # (temporary, target, flag)
    try:
        for target, (data, what) in staged.items():
            temps.append((_write_temp(target, data, what), target, what))
        _rename_all(temps)
    except BaseException:
        with _signals_held():
            for tmp, _, _ in temps:
                _unlink(tmp)
            _remove_made_dirs()
        raise
    _made_dirs.clear()
    return [target for _, target, _ in temps]


def committed() -> bool:
    """Whether the current command's files have all been renamed into place (a signal
    after that leaves them, and the command has succeeded)."""
    return _committed


def abort() -> None:
    """Drop the staged files and remove the directories made for them (if empty)."""
    global _staged
    _staged = None
    with _signals_held():
        _remove_made_dirs()


def written_bytes(path: str | Path) -> bytes:
    """The bytes written to path by this command (staged or already on disk)."""
    target = _target(Path(path))
    if _staged is not None and target in _staged:
        return _staged[target][0]
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
    else:
        _probe(parent, path, what)
    return target


def _probe(parent: Path, path: Path, what: str) -> None:
    """InputError unless a file can be made in parent (a directory that access() calls
    writable may refuse files: /proc, a read-only or full file system)."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".lathe-mirror.", suffix=".probe", dir=parent)
    except OSError as exc:
        raise InputError(f"{what} {path}: cannot write in {parent} ({exc.strerror})") from None
    os.close(fd)
    _unlink(Path(tmp))


def check_writable(path: str | Path, what: str = "-o/--output") -> Path:
    """check_target for a file whose directory must exist (kept for the writers' use)."""
    return check_target(path, what)


def write_bytes(path: str | Path, data: bytes, what: str = "-o/--output") -> Path:
    """Write data to path through a temporary name in the same directory, then rename
    (inside staging(): keep it until the command succeeds). Returns path."""
    path = Path(path)
    target = check_target(path, what)
    if _staged is not None:
        _staged[target] = (bytes(data), what)
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
    from .numbers import json_precise  # lazy: export.numbers off the CLI's start-up path

    return json.dumps(json_precise(json_ready(data)), indent=indent, allow_nan=False) + "\n"


# --------------------------------------------------------------------------------------
# Helpers


def _write_now(target: Path, data: bytes, what: str) -> Path:
    """Write one file at once (outside staging): temporary name, then rename."""
    tmp = _write_temp(target, data, what)
    try:
        with _signals_held():
            os.replace(tmp, target)
    except BaseException as exc:
        _unlink(tmp)
        if isinstance(exc, OSError):
            raise InputError(f"{what} {target}: cannot write ({exc.strerror})") from None
        raise
    return target


def _write_temp(target: Path, data: bytes, what: str) -> Path:
    """data written and synced to a new temporary name beside target (removed again if
    that fails: a full disk is an InputError naming the flag)."""
    parent = target.parent if str(target.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name[:_TMP_STEM]}.", suffix=".part", dir=parent)
    except OSError as exc:
        raise InputError(f"{what} {target}: cannot write ({exc.strerror})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())  # a full disk shows here at the latest, not after the rename
        os.chmod(tmp, 0o644)
    except BaseException as exc:
        _unlink(Path(tmp))
        if isinstance(exc, OSError):
            raise InputError(f"{what} {target}: cannot write ({exc.strerror})") from None
        raise
    return Path(tmp)


def _rename_all(temps: list[tuple[Path, Path, str]]) -> None:
    """Rename every temporary over its target with the ending signals held off; if a rename
    fails, the targets already replaced get their old files back (kept as hard links until
    the last rename) and the new ones are removed. Sets _committed before the signals are
    let through again."""
    global _committed
    done: list[tuple[Path, Path | None]] = []  # (target, its old file's link or None if new)
    with _signals_held():
        try:
            for tmp, target, what in temps:
                old = _keep_old(target)
                try:
                    os.replace(tmp, target)
                except OSError as exc:
                    if old is not None:
                        _unlink(old)
                    raise InputError(f"{what} {target}: cannot write ({exc.strerror})") from None
                done.append((target, old))
        except BaseException:
            for target, old in reversed(done):
                if old is not None:
                    try:
                        os.replace(old, target)
                    except OSError:
                        pass
                else:
                    _unlink(target)
            raise
        for _, old in done:
            if old is not None:
                _unlink(old)
        _committed = True


def _keep_old(target: Path) -> Path | None:
    """A hard link to the file target names now (None if there is none or the file system
    cannot link), so that a failed set of renames can put it back."""
    if not target.is_file():
        return None
    for k in range(100):
        link = target.with_name(f".{target.name[:_TMP_STEM]}.{os.getpid()}.{k}.old")
        try:
            os.link(target, link)
            return link
        except FileExistsError:
            continue
        except OSError:
            return None
    return None


def defer_signal(signum: int) -> bool:
    """For a signal handler: True (and the signal noted, to be raised again when the block
    ends) while a block of renames or clean-up must not be cut short."""
    if _held:
        _deferred.append(signum)
        return True
    return False


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """The ending signals held off within the block, as far as the command line's handlers
    go (they ask defer_signal): each one noted is raised again when the block ends."""
    global _held
    _held += 1
    try:
        yield
    finally:
        _held -= 1
        if not _held and _deferred:
            import signal

            pending = list(dict.fromkeys(_deferred))
            _deferred.clear()
            for signum in pending:
                signal.raise_signal(signum)


def _unlink(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


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


# --------------------------------------------------------------------------------------
# TOML


def toml_text(doc: dict[str, Any], comments=(), *, exact: bool = False) -> str:
    """A configuration dict as TOML, `comments` on top (one "# " line each). Floats at 12
    significant digits (export.numbers), or with exact=True by repr, which reads back to
    the same bits (compensate's next job: the same design, the same program)."""
    lines = [f"# {c}" for c in comments]
    if lines:
        lines.append("")
    lines += _table(doc, [], exact)
    return "\n".join(lines).rstrip("\n") + "\n"


def _table(table: dict[str, Any], path: list[str], exact: bool) -> list[str]:
    out: list[str] = []
    scalars = {k: v for k, v in table.items() if not _is_table(v) and not _is_table_array(v)}
    if scalars and path:
        out.append(f"[{'.'.join(_key(p) for p in path)}]")
    for k, v in scalars.items():
        out.append(f"{_key(k)} = {_value(v, exact)}")
    if scalars and path:
        out.append("")
    for k, v in table.items():
        if _is_table(v):
            out += _table(v, path + [k], exact)
        elif _is_table_array(v):
            for item in v:
                out.append(f"[[{'.'.join(_key(p) for p in path + [k])}]]")
                out += [f"{_key(ik)} = {_value(iv, exact)}" for ik, iv in item.items()
                        if not _is_table(iv) and not _is_table_array(iv)]
                out.append("")
                out += _table({ik: iv for ik, iv in item.items() if _is_table(iv) or _is_table_array(iv)},
                              path + [k], exact)
    return out


def _is_table(v: Any) -> bool:
    return isinstance(v, dict)


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _key(k: str) -> str:
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def _value(v: Any, exact: bool = False) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"a TOML configuration holds finite numbers only, got {v!r}")
        return repr(v) if exact else fmt_sig(v)  # 12 significant digits (export.numbers)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, exact) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} {v!r} as TOML")
