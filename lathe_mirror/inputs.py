"""Reading an input file (a configuration, a program to check, a measured profile): the one
way every command reads what a user names.

`read_input(path, what, limit)` returns the bytes of a regular file, or of stdin when the
path is `-` (asked for explicitly). Anything else (a FIFO, a process substitution
`<(...)`, a device such as /dev/zero, a socket, a directory) is refused at once without
blocking: the file is opened non-blocking and checked with fstat before a byte is read.
The size limit is checked while reading, in chunks, not only from stat (a /proc file
reports size 0, a growing file grows), so memory stays bounded by the limit; between
chunks the interpreter runs its signal handlers, so SIGINT / SIGTERM interrupt a read.

`check_input(path, what, limit)` does the same checks without reading, for readers that
take a path (x3pio, prysm, surfalize, h5py).

`memory_limit()` is the memory (bytes) any one piece of work may take: the environment's
LATHE_MIRROR_MAX_GIB, default MEMORY_LIMIT_GIB; readers check what a file declares against it
before inflating anything.

`check_number(value, what, lo, hi, unit)` refuses a number read from an input that is NaN,
infinite or outside what its quantity allows, naming the input.

`check_real(value, what, ...)` and `check_type(value, what, cls, expected)` check the
arguments of a public function given in Python: a real number (not a string, a bool or
NaN) within its range, an object of the type the function takes; the line names the
function and the argument (`what`, e.g. "plan: max_deviation").

Every refusal is an InputError whose one line names the input (`what path`) and what is
allowed: the command line exits 2.
"""

from __future__ import annotations

import math
import os
import stat
import sys
from pathlib import Path

from .errors import InputError, num

#: Bytes read at a time: a signal is handled between two reads.
CHUNK = 1 << 16
#: The path that means standard input (only when given explicitly).
STDIN = "-"
#: Memory (GiB) one piece of work may take unless LATHE_MIRROR_MAX_GIB says otherwise.
MEMORY_LIMIT_GIB = 8.0


def read_input(path: str | os.PathLike, what: str, limit: int) -> bytes:
    """The bytes of the input file path (stdin for "-"), at most `limit` bytes; InputError
    naming `what path` for anything else (see the module doc)."""
    text = str(path)
    if text == STDIN:
        return _read_stdin(what, limit)
    fd = _open_regular(Path(text), what, limit)
    try:
        return _read_bounded(fd, f"{what} {text}", limit)
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike, what: str, limit: int) -> str:
    """read_input decoded as UTF-8 (a BOM allowed); InputError if it is not UTF-8 text."""
    data = read_input(path, what, limit)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} {path}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                         f"{exc.start})") from None


def check_input(path: str | os.PathLike, what: str, limit: int) -> Path:
    """The path, after the checks read_input makes before reading: a regular file (not a
    FIFO, device, socket or directory) of at most `limit` bytes. For readers that open the
    path themselves."""
    p = Path(path)
    fd = _open_regular(p, what, limit)
    os.close(fd)
    return p


def memory_limit() -> float:
    """Bytes of memory one piece of work may take: LATHE_MIRROR_MAX_GIB (GiB), default
    MEMORY_LIMIT_GIB; InputError naming the variable if it is not a number > 0."""
    return env_number("LATHE_MIRROR_MAX_GIB", MEMORY_LIMIT_GIB) * 2.0**30


def env_number(var: str, default: float) -> float:
    """The environment variable `var` as a number > 0, `default` when unset; InputError
    naming the variable otherwise."""
    text = os.environ.get(var, "")
    try:
        value = float(text) if text else default
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"environment {var} = {text!r}: allowed a number > 0")
    return value


def check_number(value: float, what: str, lo: float | None = None, hi: float | None = None,
                 unit: str = "") -> float:
    """value as a float if it is a finite number within [lo, hi]; else InputError naming
    `what` (the input and the quantity, e.g. "--check p.ngc line 12: X")."""
    u = f" {unit}" if unit else ""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{what} = {value!r}: not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{what} = {num(v)}: must be a finite number")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        lo_t = "-inf" if lo is None else num(lo)
        hi_t = "inf" if hi is None else num(hi)
        raise InputError(f"{what} = {num(v)}{u}: allowed {lo_t} to {hi_t}{u}")
    return v


def check_real(value: object, what: str, lo: float | None = None, hi: float | None = None, unit: str = "", *,
               above: float | None = None, integer: bool = False) -> float:
    """A number argument given in Python: a real number (an int or float, numpy's too; not
    a string or a bool), finite, >= lo (or > above) and <= hi; an int if `integer`.
    InputError "what = value: ..." otherwise."""
    import numbers

    u = f" {unit}" if unit else ""
    kind = "an integer" if integer else "a number"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{what} = {short(value)} ({type(value).__name__}): expected {kind}{u and ' in' + u}")
    if integer and (not math.isfinite(value) or int(value) != value):
        raise InputError(f"{what} = {num(value)}: expected an integer")
    v = int(value) if integer else float(value)
    if not math.isfinite(v):
        raise InputError(f"{what} = {num(v)}: must be a finite number")
    if above is not None and not v > above:
        raise InputError(f"{what} = {num(v)}{u}: allowed > {num(above)}{u}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        allowed = (f">= {num(lo)}{u}" if hi is None else f"<= {num(hi)}{u}" if lo is None
                   else f"{num(lo)} to {num(hi)}{u}")
        raise InputError(f"{what} = {num(v)}{u}: allowed {allowed}")
    return v


def check_type(value: object, what: str, cls: type | tuple[type, ...], expected: str):
    """value if it is an instance of cls, else InputError "what = value (type): expected
    <expected>" (a swapped or misspelt argument named at the call, not deep inside)."""
    if not isinstance(value, cls):
        raise InputError(f"{what} = {short(value)} ({type(value).__name__}): expected {expected}")
    return value


def short(value: object) -> str:
    """A value as a one-line message shows it: repr, at most about 60 characters."""
    import reprlib

    r = reprlib.Repr()
    r.maxstring = r.maxother = 60
    return " ".join(r.repr(value).split())


# --------------------------------------------------------------------------------------
# Helpers


def _open_regular(path: Path, what: str, limit: int) -> int:
    """An open descriptor of path, a regular file of at most limit bytes (by fstat)."""
    where = f"{what} {path}"
    if str(path) == "":
        raise InputError(f"{what} '': empty path; name a file (or - for standard input)")
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise InputError(f"{where}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{where}: is a directory, expected a file") from None
    except OSError as exc:
        raise InputError(f"{where}: cannot read ({exc.strerror})") from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise InputError(f"{where}: is a directory, expected a file")
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"{where}: is {_kind(st.st_mode)}, not a regular file (give a file, or - "
                             "to read standard input)")
        if st.st_size > limit:
            raise InputError(f"{where}: {st.st_size} bytes; allowed at most {limit} bytes")
    except BaseException:
        os.close(fd)
        raise
    return fd


def _read_bounded(fd: int, where: str, limit: int) -> bytes:
    parts: list[bytes] = []
    n = 0
    while True:
        try:
            chunk = os.read(fd, min(CHUNK, limit + 1 - n))
        except BlockingIOError:  # stdin a non-blocking pipe: wait for it
            import select

            select.select([fd], [], [])
            continue
        except OSError as exc:
            raise InputError(f"{where}: cannot read ({exc.strerror})") from None
        if not chunk:
            return b"".join(parts)
        n += len(chunk)
        if n > limit:
            raise InputError(f"{where}: more than {limit} bytes; allowed at most {limit} bytes")
        parts.append(chunk)


def _read_stdin(what: str, limit: int) -> bytes:
    where = f"{what} -"
    stream = getattr(sys.stdin, "buffer", None)
    if stream is None:  # a text stream put in its place (tests)
        if sys.stdin is None:
            raise InputError(f"{where}: no standard input")
        text = sys.stdin.read(limit + 1)
        data = text.encode("utf-8")
        if len(text) > limit or len(data) > limit:
            raise InputError(f"{where}: more than {limit} bytes; allowed at most {limit} bytes")
        return data
    try:
        fd = stream.fileno()
    except (OSError, ValueError, AttributeError):
        fd = None
    if fd is None:
        try:
            data = stream.read(limit + 1)
        except OSError as exc:  # e.g. no standard input to read (a test runner's)
            raise InputError(f"{where}: cannot read standard input ({exc})") from None
        if len(data) > limit:
            raise InputError(f"{where}: more than {limit} bytes; allowed at most {limit} bytes")
        return data
    return _read_bounded(fd, where, limit)


def _kind(mode: int) -> str:
    if stat.S_ISFIFO(mode):
        return "a FIFO or pipe"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a special file"
