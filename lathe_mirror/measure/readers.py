"""Measured profiles and maps, read by the libraries that know each format, in mm.

A trace (`Trace`) is a profile across the part through (near) its axis, in the machine
frame as a profilometer sees the part face up (ARCHITECTURE.md, "Measured profiles"): x
along the trace, z the height, both mm; the part's vertex is its highest point. An
areal map (`AreaMap`: x, y, z in mm, NaN where not measured) is cut through its fitted
axis into a trace by `fit.profile_through_axis`.

Formats (`MeasuredFormat`, from the file's suffix unless --format says):
  csv       CSV / whitespace text: two columns x, z (or r, z); a header may name them and
            their units (`x_mm,z_mm`, `x [um], z [um]`, `r (mm) z (nm)`); no header: mm
  prf       Taylor Hobson's ASCII profile (`CX` / `CZ` axis lines with unit and scale,
            `SPACING` with its unit, the heights after the second `EOR`)
  x3p       ISO 5436-2 / ISO 25178-72 (x3pio; metres, NaN not measured): profile or map
  datx      Zygo MX (prysm.io.read_zygo_datx, needs h5py): map, heights nm
  dat       Zygo MetroPro binary (prysm.io.read_zygo_dat): map, heights nm
  surfalize any areal format surfalize reads (.sur, .plu, .vk4, .sdf, ...): heights um
Every file is read through `read_bytes_checked` (inputs.read_input: a regular file, at most
MAX_BYTES); the libraries are handed the bytes, never the path. What a container declares
(an .x3p's zip members and grid, a .datx's links, storage and shapes) is checked before its
library inflates it, and every coordinate read is finite and of a size a part can have
(measure.bounds).
"""

from __future__ import annotations

import csv
import io
import math
import re
import warnings
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from ..enums import parse
from ..errors import InputError
from ..inputs import read_input
from . import bounds

#: Largest measured file read (bytes): a 4k x 4k float64 map is 128 MiB.
MAX_BYTES = 256 << 20

#: Fewest points a trace must have to be fitted.
MIN_POINTS = 50

#: Lines of a text trace beyond its points (header, comments) counted before it is split.
_MAX_TEXT_HEADER_LINES = 1024

_UNITS_MM = {"m": 1e3, "mm": 1.0, "um": 1e-3, "µm": 1e-3, "micron": 1e-3, "microns": 1e-3,
             "nm": 1e-6, "in": 25.4, "inch": 25.4}


class MeasuredFormat(str, Enum):
    """The formats `lathe-mirror measure` reads (module doc)."""

    CSV = "csv"
    PRF = "prf"
    X3P = "x3p"
    DATX = "datx"
    DAT = "dat"
    SURFALIZE = "surfalize"


_SUFFIX = {".csv": MeasuredFormat.CSV, ".txt": MeasuredFormat.CSV, ".xz": MeasuredFormat.CSV,
           ".prf": MeasuredFormat.PRF, ".x3p": MeasuredFormat.X3P, ".datx": MeasuredFormat.DATX,
           ".dat": MeasuredFormat.DAT}
_SURFALIZE_SUFFIXES = (".sur", ".plu", ".plux", ".vk3", ".vk4", ".vk6", ".vk7", ".sdf", ".tmd",
                       ".sflz", ".al3d", ".opd", ".zon", ".gwy", ".nms", ".os3d", ".lext", ".oir",
                       ".zmg", ".hdat", ".fits", ".fit")


@dataclass(frozen=True)
class Trace:
    """A measured profile: x along the trace and z the height, mm (machine frame, part face
    up), sorted by x, finite. source: the file and format, for messages and the report."""

    x: np.ndarray
    z: np.ndarray
    source: str


@dataclass(frozen=True)
class AreaMap:
    """A measured height map: x (columns) and y (rows) in mm, z (rows, columns) in mm, NaN
    where not measured."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    source: str


def format_of(path: str | Path, fmt: str | None = None) -> MeasuredFormat:
    """The format of a measured file: `fmt` (--format) if given, else by its suffix."""
    if fmt is not None:
        return parse(MeasuredFormat, fmt, "--format")
    suffix = Path(path).suffix.lower()
    if suffix in _SUFFIX:
        return _SUFFIX[suffix]
    if suffix in _SURFALIZE_SUFFIXES:
        return MeasuredFormat.SURFALIZE
    known = sorted(set(_SUFFIX) | set(_SURFALIZE_SUFFIXES))
    raise InputError(f"{path}: unknown measurement suffix {suffix or '(none)'!r}; allowed "
                     f"{', '.join(known)} (or name it with --format)")


def read_bytes_checked(path: str | Path) -> bytes:
    """The whole content of a measured file through inputs.read_input (a regular file or
    stdin '-', at most MAX_BYTES, limited while reading): the one place a measured file is
    read. InputError otherwise."""
    return read_input(path, "measured file", MAX_BYTES)


def read_measurement(path: str | Path, fmt: str | None = None) -> Trace | AreaMap:
    """A measured file as a Trace or an AreaMap, in mm. InputError (one line) if the file is
    not what its format says."""
    kind = format_of(path, fmt)
    data = read_bytes_checked(path)
    name = f"{Path(path).name} ({kind.value})"
    try:
        # an overflow to inf is refused by _checked, naming the field: no numpy warning on stderr
        with np.errstate(over="ignore", invalid="ignore"):
            out = _read_kind(path, data, kind, name)
    except InputError:
        raise
    except Exception as exc:  # the library's own complaint, on one line
        raise InputError(f"{path}: not a readable {kind.value} file ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:200]})") from None
    return _checked(out, path)


def _read_kind(path, data: bytes, kind: MeasuredFormat, name: str) -> Trace | AreaMap:
    if kind is MeasuredFormat.X3P:
        bounds.check_x3p(data, name)
        return _read_x3p(data, name)
    if kind is MeasuredFormat.DATX:
        bounds.check_hdf5(data, name)
    if kind is MeasuredFormat.CSV:
        return _read_text(data, name)
    if kind is MeasuredFormat.PRF:
        return _read_prf(data, name)
    if kind in (MeasuredFormat.DATX, MeasuredFormat.DAT):
        return _read_zygo(path, data, kind, name)
    suffix = Path(path).suffix.lower()
    if suffix == ".zon" or data.startswith(b"KPK"):  # Keyence's zip behind a preview, its members zstd
        bounds.check_zon(data, name)
    else:
        bounds.check_zip(data, name)
    return _read_surfalize(data, suffix, name)


def _checked(out: Trace | AreaMap, path) -> Trace | AreaMap:
    """The reader's output with every coordinate finite and bounded (NaN: not measured,
    left out of a trace), a trace sorted by x; InputError naming the file and the field."""
    if isinstance(out, Trace):
        bounds.check_finite(out.x, out.source, "x")
        bounds.check_finite(out.z, out.source, "z")
        ok = np.isfinite(out.x) & np.isfinite(out.z)
        x, z = out.x[ok], out.z[ok]
        if x.size < MIN_POINTS:
            raise InputError(f"{path}: {x.size} measured points; a trace needs at least {MIN_POINTS}")
        order = np.argsort(x, kind="stable")
        return Trace(x[order], z[order], out.source)
    for field, v in (("x", out.x), ("y", out.y), ("z", out.z)):
        bounds.check_finite(v, out.source, field)
    if out.z.ndim != 2 or np.count_nonzero(np.isfinite(out.z)) < MIN_POINTS:
        raise InputError(f"{path}: fewer than {MIN_POINTS} measured points in the map")
    if out.z.shape[0] == 1 or out.z.shape[1] == 1:  # a map of one row is a profile
        z = out.z.ravel()
        x = out.x if out.z.shape[0] == 1 else out.y
        return _checked(Trace(np.asarray(x, float), z, out.source), path)
    return out


# --------------------------------------------------------------------------------------
# Text


def _unit_in(label: str) -> float | None:
    """mm per unit named in a column label (`x_mm`, `z [um]`, `r (nm)`), None if none."""
    m = re.search(r"[\[(_ ]\s*(m|mm|um|µm|nm|in|inch|microns?)\s*[\])]?\s*$", label.strip().lower())
    return _UNITS_MM[m.group(1)] if m else None


def _read_text(data: bytes, name: str) -> Trace:
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{name}: not text (a CSV trace is UTF-8 text)") from None
    n_lines = text.count("\n") + 1
    if n_lines > bounds.MAX_TRACE_POINTS + _MAX_TEXT_HEADER_LINES:  # before a list of lines is made
        bounds.check_trace_points(n_lines, name, "lines")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    bounds.check_trace_points(len(lines) - 1, name)
    if not lines:
        raise InputError(f"{name}: empty; expected two columns x, z (mm)")
    delim = "," if "," in lines[0] else ";" if ";" in lines[0] else None
    first = next(csv.reader(lines[:1], delimiter=delim)) if delim else lines[0].split()
    header = None
    try:
        [float(v) for v in first[:2]]
    except ValueError:
        header, lines = first, lines[1:]
    if header is not None:
        names = [h.strip().lower() for h in header]
        if len(names) < 2 or not names[0][:1] in ("x", "r") or not names[1][:1] in ("z", "h", "y"):
            raise InputError(f"{name}: header {','.join(header)!r}; expected columns x (or r) and z, "
                             "with units (x_mm,z_mm)")
        sx = _unit_in(names[0]) or 1.0
        sz = _unit_in(names[1]) or 1.0
    else:
        sx = sz = 1.0
    arr = _two_columns(lines, delim)
    if arr is None:  # a row of other than two numbers: each row read, the first bad one named
        rows = csv.reader(lines, delimiter=delim) if delim else (ln.split() for ln in lines)
        try:
            arr = np.array([[float(v) for v in row[:2]] for row in rows], dtype=float)
        except (ValueError, IndexError):
            raise InputError(f"{name}: a row is not two numbers x, z") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InputError(f"{name}: expected two columns x, z")
    return Trace(arr[:, 0] * sx, arr[:, 1] * sz, name)


def _two_columns(lines: list[str], delim: str | None) -> np.ndarray | None:
    """The first two columns of every row, parsed by numpy's C reader (no Python float per
    value); None if a row has fewer than two or a value is not a number."""
    try:
        return np.loadtxt(io.StringIO("\n".join(lines)), delimiter=delim, usecols=(0, 1), ndmin=2,
                          comments=None, dtype=float)
    except ValueError:
        return None


def _read_prf(data: bytes, name: str) -> Trace:
    """Taylor Hobson's ASCII profile: header records up to the second `EOR`, then the
    heights (whitespace-separated) up to an `EOR` or the end. Heights are value x the CZ
    line's scale (metres; the NPL reference files write `CZ M n UM 1.0e-6 L`); x is the
    point index x SPACING (in its unit)."""
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise InputError(f"{name}: not ASCII text; a .prf profile is Taylor Hobson's ASCII export") from None
    eor = [m.start() for m in re.finditer(r"(?im)^[ \t]*EOR\b", text)]
    if len(eor) < 2:
        raise InputError(f"{name}: no header ending in two EOR records; not a Taylor Hobson .prf")
    header = [ln.split() for ln in text[:eor[1]].splitlines()]
    cz = next((t for t in header if t and t[0].upper() == "CZ"), None)
    spacing = next((t for t in header if t and t[0].upper() == "SPACING"), None)
    if cz is None or spacing is None:
        raise InputError(f"{name}: the header has no {'CZ' if cz is None else 'SPACING'} record")
    try:
        z_scale_mm = float(cz[4]) * 1e3
        unit = spacing[1].lower()
        spacing_mm = float(spacing[2]) * _UNITS_MM[unit]
    except (IndexError, ValueError, KeyError):
        raise InputError(f"{name}: CZ or SPACING record not understood ({' '.join(cz)}; {' '.join(spacing)})") from None
    if not (math.isfinite(z_scale_mm) and z_scale_mm != 0.0):
        raise InputError(f"{name}: CZ scale = {cz[4]} m: allowed a finite number other than 0")
    dx = bounds.check_spacing(spacing_mm, name, "SPACING")
    start = text.find("\n", eor[1]) + 1 if "\n" in text[eor[1]:] else len(text)
    end = eor[2] if len(eor) > 2 else len(text)
    body = text[start:end] if start < end else ""
    bounds.check_trace_points(_count_words(data[start:end] if start < end else b""), name, "heights")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            z = np.fromstring(body, sep=" ") if body.strip() else np.zeros(0)
        except (ValueError, DeprecationWarning):
            raise InputError(f"{name}: a height after the header is not a number") from None
    return Trace(np.arange(z.size) * dx, z * z_scale_mm, name)


def _count_words(data: bytes, chunk: int = 1 << 24) -> int:
    """Whitespace-separated words in data, counted in chunks (memory bounded by the chunk)."""
    n, prev_space = 0, True
    for i in range(0, len(data), chunk):
        space = np.frombuffer(data[i:i + chunk], np.uint8) <= 32
        before = np.concatenate(([prev_space], space[:-1]))
        n += int(np.count_nonzero(~space & before))
        prev_space = bool(space[-1])
    return n


# --------------------------------------------------------------------------------------
# Libraries


def _read_x3p(data: bytes, name: str) -> Trace | AreaMap:
    import x3pio

    f = x3pio.read(io.BytesIO(data))
    layer = f.layers[0]
    pts = layer.points()  # metres, global frame
    if isinstance(f, x3pio.Profile):
        return Trace(pts[:, 0] * 1e3, pts[:, 2] * 1e3, name)
    if isinstance(f, x3pio.Surface):
        x = pts[0, :, 0] * 1e3
        y = pts[:, 0, 1] * 1e3
        return AreaMap(x, y, pts[:, :, 2] * 1e3, name)
    raise InputError(f"{name}: a point cloud; measure takes a profile or a gridded map")


def _read_zygo(path, data: bytes, kind, name: str) -> AreaMap:
    import tempfile

    with warnings.catch_warnings():  # prysm's import warns about pkg_resources
        warnings.simplefilter("ignore")
        from prysm import io as pio

    # prysm opens files by name: hand it the bytes already checked
    with tempfile.TemporaryDirectory(prefix="lathe-mirror-") as tmp:
        p = Path(tmp) / f"m{'.datx' if kind is MeasuredFormat.DATX else '.dat'}"
        p.write_bytes(data)
        d = pio.read_zygo_datx(p) if kind is MeasuredFormat.DATX else pio.read_zygo_dat(p)
    phase = np.asarray(d["phase"], dtype=float)  # nm
    meta = d.get("meta") or {}
    res = meta.get("Lateral Resolution", meta.get("lateral_resolution"))  # m per pixel
    if res is None:
        raise InputError(f"{name}: no lateral resolution in the file; cannot place its pixels")
    try:
        res_mm = float(np.asarray(res, dtype=float).ravel()[0]) * 1e3
    except (TypeError, ValueError, IndexError, OverflowError):
        raise InputError(f"{name}: Lateral Resolution = {res!r}: not a number") from None
    dx = bounds.check_spacing(res_mm, name, "Lateral Resolution")
    ny, nx = phase.shape
    return AreaMap(np.arange(nx) * dx, np.arange(ny) * dx, phase * 1e-6, name)


def _read_surfalize(data: bytes, suffix: str, name: str) -> AreaMap:
    import surfalize

    with warnings.catch_warnings():  # its notes (pixel aspect, suffix guesses) are not errors here
        warnings.simplefilter("ignore")
        s = surfalize.Surface.load(io.BytesIO(data), format=suffix)
    dx = bounds.check_spacing(float(s.step_x) * 1e-3, name, "step_x")
    dy = bounds.check_spacing(float(s.step_y) * 1e-3, name, "step_y")
    z = np.asarray(s.data, dtype=float) * 1e-3  # um -> mm
    ny, nx = z.shape
    return AreaMap(np.arange(nx) * dx, np.arange(ny) * dy, z, name)
