"""What a measured file may hold, checked before a byte of it is inflated or trusted.

A measured file is at most `readers.MAX_BYTES` on disk, but a zip (.x3p) or an HDF5 file
(.datx) declares data that can inflate far beyond that, and an HDF5 dataset can live in
another file (external storage, a virtual dataset, an external link). So each container is
read for what it declares before its library is handed the bytes:

  x3p   every zip member's declared size (the description, main.xml, at most
        MAX_DESCRIPTION_BYTES), the grid main.xml declares (x3pio.info reads only the
        description), and the members together no larger than that grid stored as float64
        x, y, z with validity bits;
  datx  every link inside the file (no external or soft link), every dataset stored in
        the file (no external storage, no virtual dataset) and its declared shape x itemsize.
  a zip of surfalize's (.plux, .vk6, ...): its members' declared sizes (check_zip);
  zon   Keyence's zip behind a preview image (surfalize reads it): its members' declared
        sizes, then each member that is a zstd stream (whose frames need not declare their
        size) decompressed as a stream, counted a chunk at a time and never held, stopping
        at the limit (check_zon).

The grid's working memory (`BYTES_PER_POINT` per measured point) is checked against
`memory_limit()` (LATHE_MIRROR_MAX_GIB, the limit the commands' cost estimates use).
A trace read from text is held to `MAX_TRACE_POINTS`.

`check_finite` is the other half: every coordinate a reader returns is a finite number of a
size a part can have (NaN means "not measured" and is left out; an infinity or a coordinate
beyond `MAX_COORD_MM` is refused), so no fit or image downstream meets an overflow.
Every refusal is an InputError naming the file and the field.
"""

from __future__ import annotations

import io
import math

import numpy as np

from ..errors import InputError, num
from ..inputs import memory_limit

#: Working memory per measured point of a map (bytes): the library's array, its x, y, z
#: points (x3pio) or NaN-masked copy (prysm), the map in mm and the axis fit's copies, all
#: float64. Measured peak RSS over a 2000 x 2000 map's read: 62.4 B/point for .x3p, 33.6
#: for .datx (benchmarks/bench_measured_memory.py).
BYTES_PER_POINT = 64

#: Largest trace read from text (points): twice the finest profilometer trace of a lathe
#: part (0.125 um spacing over 120 mm is 960,000 points); numpy parses it in about 2 s.
MAX_TRACE_POINTS = 1 << 21

#: Largest description member of an x3p (main.xml, checksums, vendor files), inflated.
MAX_DESCRIPTION_BYTES = 32 << 20

#: Largest coordinate of a measured point (mm): no instrument measures a lathe part over
#: 10 m, and below it sums of squares of a million points stay far from overflow.
MAX_COORD_MM = 1.0e4

_X3P_BYTES_PER_POINT = 3 * 8 + 1  # x, y, z as float64 and a validity bit, rounded up to a byte


def check_points(points: int, name: str, what: str) -> None:
    """Refuse a map of `points` measured points whose working memory exceeds the limit."""
    need = points * BYTES_PER_POINT
    limit = memory_limit()
    if need > limit:
        raise InputError(f"{name}: {what} declares {points} points, which need about {_gib(need)} of memory; "
                         f"limit {_gib(limit)} (LATHE_MIRROR_MAX_GIB)")


def check_trace_points(count: int, name: str, what: str = "rows") -> None:
    """Refuse a text trace of more than MAX_TRACE_POINTS points (`count` of `what`)."""
    if count > MAX_TRACE_POINTS:
        raise InputError(f"{name}: {count} {what}; a trace is allowed at most {MAX_TRACE_POINTS} points "
                         "(thin it)")


def check_x3p(data: bytes, name: str) -> None:
    """An .x3p's zip members and declared grid within the bounds (module doc), before x3pio
    inflates anything."""
    import zipfile

    try:
        members = zipfile.ZipFile(io.BytesIO(data)).infolist()
    except (zipfile.BadZipFile, ValueError, OSError, EOFError):
        return  # not a zip: x3pio says so in its own words
    for m in members:
        if m.filename.rsplit("/", 1)[-1].lower() == "main.xml" and m.file_size > MAX_DESCRIPTION_BYTES:
            raise InputError(f"{name}: member {m.filename!r} inflates to {m.file_size} bytes; a description "
                             f"is allowed at most {MAX_DESCRIPTION_BYTES} bytes")
    import x3pio

    info = x3pio.info(io.BytesIO(data), verify=False)
    points = math.prod(int(n) for n in info.shape) * max(int(info.layer_count), 1)
    check_points(points, name, f"its grid ({' x '.join(str(n) for n in info.shape)}, "
                               f"{info.layer_count} layer(s))")
    allowed = points * _X3P_BYTES_PER_POINT + MAX_DESCRIPTION_BYTES
    total = sum(m.file_size for m in members)
    if total > allowed:
        big = max(members, key=lambda m: m.file_size)
        raise InputError(f"{name}: its members inflate to {total} bytes ({big.filename!r}: {big.file_size}); "
                         f"its {points}-point grid allows at most {allowed} bytes")


def check_zip(data: bytes, name: str) -> None:
    """A zip container of another format (surfalize's .plux, .vk6, .vk7, ...): its members'
    declared sizes, inflated and then held as float64 maps (BYTES_PER_POINT / 8 bytes of
    working memory per inflated byte, at most), within the memory limit. A .zon, whose
    members are zstd streams that declare no size, is check_zon's."""
    import zipfile

    if not data.startswith(b"PK\x03\x04"):
        return
    try:
        members = zipfile.ZipFile(io.BytesIO(data)).infolist()
    except (zipfile.BadZipFile, ValueError, OSError, EOFError):
        return
    total = sum(m.file_size for m in members)
    need = total * (BYTES_PER_POINT // 8)
    limit = memory_limit()
    if need > limit:
        big = max(members, key=lambda m: m.file_size)
        raise InputError(f"{name}: its members inflate to {total} bytes ({big.filename!r}: {big.file_size}), which "
                         f"need about {_gib(need)} of memory; limit {_gib(limit)} (LATHE_MIRROR_MAX_GIB)")


#: The zstd frame's magic number (RFC 8878, 3.1.1): a .zon member that starts with it is
#: decompressed by surfalize whole, however large.
ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
#: Bytes decompressed at a time while a zstd member is counted.
_ZSTD_CHUNK = 1 << 20


def check_zon(data: bytes, name: str) -> None:
    """A .zon's members within the memory limit before surfalize reads it: the zip's
    declared sizes (as check_zip), then each member that starts with ZSTD_MAGIC
    decompressed as a stream across all its frames (surfalize decompresses it whole, and
    its frames need not declare a size) and counted, never held, stopping as soon as the
    members together inflate past the limit: memory_limit() / (BYTES_PER_POINT / 8) bytes,
    each inflated byte held as a float64 map's share at most, as check_zip. Nothing of the
    format is parsed here: the zip is found from its end as zipfile finds any zip (the
    preview image before it is data zipfile skips)."""
    import zipfile

    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        members = archive.infolist()
    except (zipfile.BadZipFile, ValueError, OSError, EOFError):
        return  # no zip in it: surfalize says so in its own words
    per_byte = BYTES_PER_POINT // 8
    limit = memory_limit()
    allowed = int(limit // per_byte)
    declared = sum(m.file_size for m in members)
    if declared > allowed:
        big = max(members, key=lambda m: m.file_size)
        raise InputError(f"{name}: its members inflate to {declared} bytes ({big.filename!r}: {big.file_size}), which "
                         f"need about {_gib(declared * per_byte)} of memory; limit {_gib(limit)} (LATHE_MIRROR_MAX_GIB)")
    total = declared
    for m in members:
        try:
            with archive.open(m) as f:
                if f.read(len(ZSTD_MAGIC)) != ZSTD_MAGIC:
                    continue
            with archive.open(m) as f:
                inflated = _zstd_inflated(f, allowed - total + m.file_size + 1)
        except (zipfile.BadZipFile, RuntimeError, NotImplementedError, OSError, EOFError, ValueError) as exc:
            raise InputError(f"{name}: member {m.filename!r} cannot be read ({type(exc).__name__}: "
                             f"{' '.join(str(exc).split())[:200]})") from None
        total += inflated - m.file_size  # the stream's inflated bytes held in place of its own
        if total > allowed:
            raise InputError(f"{name}: member {m.filename!r} is a zstd stream that inflates to at least {inflated} "
                             f"bytes, the members together past the {allowed} bytes whose float64 maps fit the "
                             f"memory limit of {_gib(limit)} (LATHE_MIRROR_MAX_GIB)")


def _zstd_inflated(stream, cap: int) -> int:
    """The bytes the zstd frames read from `stream` inflate to, counted _ZSTD_CHUNK at a
    time and never held; the count stops at `cap` (a stream that reaches it inflates at
    least that far). zstandard, the package surfalize reads zstd with below Python 3.14,
    else the standard library's compression.zstd (what it uses from 3.14; not exercised
    by the tests on 3.11). A broken stream raises ValueError."""
    try:
        import zstandard
    except ImportError:  # Python >= 3.14
        from compression.zstd import ZstdError, ZstdFile

        reader, error = ZstdFile(stream), ZstdError
    else:
        reader, error = zstandard.ZstdDecompressor().stream_reader(stream, read_across_frames=True), zstandard.ZstdError
    n = 0
    try:
        with reader:
            while n < cap:
                chunk = reader.read(min(_ZSTD_CHUNK, cap - n))
                if not chunk:
                    break
                n += len(chunk)
    except error as exc:
        raise ValueError(f"a broken zstd stream: {exc}") from None
    return n


def check_hdf5(data: bytes, name: str) -> None:
    """An HDF5 file (.datx) holds its data itself and declares no more than the limit: every
    link a hard link, every dataset stored in the file, not virtual, its shape x itemsize
    counted (module doc)."""
    import h5py

    try:
        f = h5py.File(io.BytesIO(data), "r")
    except (OSError, ValueError):
        return  # not HDF5: prysm says so in its own words
    with f:
        refused: list[str] = []
        datasets: list[tuple[str, int, int]] = []

        def visit(path: str, link) -> None:
            if refused:
                return
            if isinstance(link, h5py.ExternalLink):
                refused.append(f"{path!r} links to {link.filename!r}, another file; the data must be in the file")
            elif isinstance(link, h5py.SoftLink):
                refused.append(f"{path!r} is a soft link (to {link.path!r}); the data must be stored in place")
            elif isinstance(link, h5py.HardLink):
                obj = f.get(path)
                if isinstance(obj, h5py.Dataset):
                    if obj.external:
                        refused.append(f"dataset {path!r} is stored in another file ({obj.external[0][0]!r}); "
                                       "the data must be in the file")
                    elif obj.is_virtual:
                        refused.append(f"dataset {path!r} is virtual (mapped from other files); the data must "
                                       "be in the file")
                    else:
                        shape = obj.shape or ()
                        n = math.prod(int(s) for s in shape)
                        datasets.append((path, n, n * int(obj.dtype.itemsize)))

        f.visititems_links(visit)
        if refused:
            raise InputError(f"{name}: {refused[0]}")
    if not datasets:
        return
    limit = memory_limit()
    total = sum(nbytes for _, _, nbytes in datasets)
    path, points, nbytes = max(datasets, key=lambda d: d[2])
    need = total + points * BYTES_PER_POINT
    if need > limit:
        raise InputError(f"{name}: dataset {path!r} declares {points} points ({nbytes} bytes; {total} bytes in "
                         f"all), which need about {_gib(need)} of memory; limit {_gib(limit)} "
                         "(LATHE_MIRROR_MAX_GIB)")


def check_finite(values: np.ndarray, name: str, field: str, unit: str = "mm") -> None:
    """Refuse an infinite value or one beyond MAX_COORD_MM in `values` (NaN, "not
    measured", is let through), naming the file, the field and the first such point."""
    v = np.asarray(values, dtype=float)
    bad = np.isinf(v) | (np.abs(np.nan_to_num(v)) > MAX_COORD_MM)
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        where = f" at point {i}" if v.ndim == 1 else f" at {tuple(int(k) for k in np.unravel_index(i, v.shape))}"
        raise InputError(f"{name}: {field} = {num(float(v.ravel()[i]))} {unit}{where}: allowed a finite number "
                         f"from {num(-MAX_COORD_MM)} to {num(MAX_COORD_MM)} {unit}")


def check_spacing(value, name: str, field: str, unit: str = "mm") -> float:
    """A sampling interval read from a file: a finite number > 0 and at most MAX_COORD_MM."""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name}: {field} = {value!r}: not a number") from None
    if not (math.isfinite(v) and 0 < v <= MAX_COORD_MM):
        raise InputError(f"{name}: {field} = {num(v)} {unit}: allowed a finite number > 0, at most "
                         f"{num(MAX_COORD_MM)} {unit}")
    return v


def _gib(nbytes: float) -> str:
    return f"{nbytes / 2**30:.3g} GiB"
