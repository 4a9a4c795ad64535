"""The precision of every number lathe-mirror writes, and the one formatter that applies it.

A number in a written file (G-code, DXF, STEP, YAML, TXT, JSON, TOML) is rounded to a
stated precision, a power of ten far below anything physical and far above the last bit
of double arithmetic, so a newer numpy, another BLAS or another CPU cannot change the
bytes (the float noise of a result near 100 mm is about 1e-14 mm; the lathe's lattice is
5e-3 mm). The precisions, as the decimal exponent of the last digit written:

=================  ========  ===========================================================
quantity           last      why
=================  ========  ===========================================================
length (mm)        1e-9 mm   1 pm: 1e6 below the lattice, 1e5 above float noise at 1 m
length (um, nm)    1e-6 um,  the same 1e-9 mm
                   1e-3 nm
length (m)         1e-12 m   the same 1e-9 mm (Kalibr's baselines)
area, volume       1e-9      mm^2, mm^3 (the CAD check's volume)
angle (rad)        1e-12     1 prad: 1e-12 mm of arc at 1 m ... 1e-10 mm at 100 m
angle (deg)        1e-10     about 1.7e-12 rad
pixel (px)         1e-6 px   9 nm on the paper's 9 um pixels
time (s)           1e-6 s
percent (%)        1e-9 %
ratio              1e-12     dimensionless: xi, distortion, direction cosines, weights
a polynomial       1e-6 px   OCamCalib's coefficients: each term a_i rho^i to 1e-6 px at
coefficient                  the largest image radius rho_max (`polynomial_exponent`)
no unit known      12 sig.   relative, 12 significant digits (a JSON value whose key
                   digits    carries no unit suffix, e.g. a count or a yield fraction)
=================  ========  ===========================================================

Rounding is half-even on the exact binary value (decimal.Decimal(x)); a number is written
fixed-point (trailing zeros dropped, at least one decimal) or, when the precision is finer
than 1e-12 or the number is 1e15 or more, in scientific notation with as many digits as the
precision asks. A value that sits within a few ulps of a rounding boundary could still round
either way; at these precisions that needs a value whose decimal expansion has a 5 at
exactly the written place followed by ~6 zeros, about one number in a million.

Writers: export/gcode (the lattice words are exact multiples of the resolution; comments
through `fmt`), export/dxf (every float group code of the DXF through `dxf_text`),
export/step (every REAL of the DATA section through `step_text`), export/calib,
export/design_toml, export/files.json_text (JSON by key suffix: `json_precise`), report/.
"""

from __future__ import annotations

import math
import re
from decimal import ROUND_HALF_EVEN, Context, Decimal
from typing import Any

# Decimal exponents of the last digit written (see the table above).
LENGTH_MM = -9
LENGTH_UM = -6
LENGTH_NM = -3
LENGTH_M = -12
AREA_MM2 = -9
VOLUME_MM3 = -9
ANGLE_RAD = -12
ANGLE_DEG = -10
PIXEL = -6
TIME_S = -6
PERCENT = -9
RATIO = -12
SIGNIFICANT_DIGITS = 12

_CTX = Context(prec=80)

#: JSON key suffix -> precision exponent; the unit of a key holds for the values under it
#: (`"normal_deviation_mm": {"rms": ..., "max": ...}`). Longest suffix first.
UNIT_SUFFIXES: tuple[tuple[str, int], ...] = (
    ("_mm3", VOLUME_MM3), ("_mm2", AREA_MM2), ("_mm", LENGTH_MM), ("_um", LENGTH_UM),
    ("_nm", LENGTH_NM), ("_m", LENGTH_M), ("_rad", ANGLE_RAD), ("_deg", ANGLE_DEG),
    ("_px", PIXEL), ("_pct", PERCENT), ("_percent", PERCENT), ("_s", TIME_S),
)


def quantize(x: float, exp: int) -> Decimal:
    """x rounded half-even to a multiple of 10**exp (exact decimal)."""
    if not math.isfinite(x):
        raise ValueError(f"cannot write the non-finite number {x!r}")
    return _CTX.quantize(Decimal(float(x)), Decimal(1).scaleb(exp))


def rounded(x: float, exp: int) -> float:
    """x rounded to a multiple of 10**exp, as the nearest float (what a library that
    writes repr(float) then writes as that short decimal)."""
    q = quantize(x, exp)
    return 0.0 if q == 0 else float(q)


def fmt(x: float, exp: int) -> str:
    """x at the precision 10**exp: fixed-point with trailing zeros dropped (at least one
    decimal: "2.0", "-0.125"), or scientific ("1.234567e-10") when exp < -12 or
    |x| >= 1e15. Zero is "0.0", never "-0.0"."""
    q = quantize(x, exp)
    if q == 0:
        return "0.0"
    if exp >= -12 and abs(q) < Decimal("1e15"):
        s = format(q, "f")
        if "." in s:
            s = s.rstrip("0")
            return s + "0" if s.endswith(".") else s
        return s + ".0"
    sign, digits, e = q.normalize(_CTX).as_tuple()
    head = str(digits[0])
    tail = "".join(str(d) for d in digits[1:])
    power = e + len(digits) - 1
    return f"{'-' if sign else ''}{head}{'.' + tail if tail else '.0'}e{power:+03d}"


def significant_exponent(x: float, digits: int = SIGNIFICANT_DIGITS) -> int:
    """The exponent that keeps `digits` significant digits of x."""
    if x == 0 or not math.isfinite(x):
        return 0
    return math.floor(math.log10(abs(x))) - digits + 1


def fmt_sig(x: float, digits: int = SIGNIFICANT_DIGITS) -> str:
    """x to `digits` significant digits (a number with no unit)."""
    return fmt(x, significant_exponent(x, digits))


def polynomial_exponent(power: int, rho_max: float, exp: int = PIXEL) -> int:
    """The precision of a polynomial coefficient a_power in pixels: a_power rho^power is
    written to 10**exp px at rho = rho_max."""
    return exp - math.ceil(power * math.log10(max(rho_max, 1.0)))


def mm(x: float) -> str:
    return fmt(x, LENGTH_MM)


def px(x: float) -> str:
    return fmt(x, PIXEL)


def ratio(x: float) -> str:
    return fmt(x, RATIO)


def unit_exponent(key: str) -> int | None:
    """The precision of a JSON value named `key` (by its unit suffix), or None."""
    for suffix, exp in UNIT_SUFFIXES:
        if key.endswith(suffix):
            return exp
    return None


def column_exponent(name: str) -> int | None:
    """The precision of a table column (the Monte Carlo's CSV) by its name: a lobe suffix
    (_inner, _outer) and a statistic suffix (_rms, _max, _p90, ...) set aside, the unit
    suffix's (`unit_exponent`); None when the name carries no unit."""
    for lobe in ("_inner", "_outer"):
        name = name.removesuffix(lobe)
    own = unit_exponent(name)
    if own is None:
        head, _, stat = name.rpartition("_")
        if stat in STATISTICS or stat in ("p90", "p10"):
            own = unit_exponent(head)
    return own


def csv_cell(name: str, value: Any) -> Any:
    """A CSV cell of column `name`: a float at its column's precision (`column_exponent`,
    else 12 significant digits; "nan" where a figure could not be computed), anything
    else as it is."""
    if isinstance(value, float):
        if not math.isfinite(value):
            return repr(value)
        exp = column_exponent(name)
        return fmt(value, exp if exp is not None else significant_exponent(value))
    return value


#: Keys of a figure's statistics: they take the unit of the key that holds them
#: (`"normal_deviation_mm": {"rms": x, "max": y}`).
STATISTICS = frozenset({"rms", "max", "min", "mean", "median", "std", "p5", "p50", "p95", "p99",
                        "pv", "lo", "hi", "value"})


def json_precise(x: Any, exp: int | None = None) -> Any:
    """A copy of a JSON-ready tree whose floats are rounded at their stated precision: a
    number (or list of numbers) under a key with a unit suffix (`unit_exponent`) at that
    unit's, as are the statistics of such a key (`STATISTICS`); any other float at 12
    significant digits (`"at_2_m": {"exact": {"rms": ...}}` names a range, not a unit, of
    what it holds). Booleans, integers, strings and None pass unchanged."""
    if isinstance(x, dict):
        out = {}
        for k, v in x.items():
            own = unit_exponent(k) if isinstance(k, str) else None
            if own is None and exp is not None and k in STATISTICS:
                own = exp
            if isinstance(v, dict) and not (set(v) <= STATISTICS):
                own = None  # a unit names the numbers, not a section
            out[k] = json_precise(v, own)
        return out
    if isinstance(x, list):
        return [json_precise(v, exp) for v in x]
    if isinstance(x, float) and math.isfinite(x):
        return rounded(x, exp if exp is not None else significant_exponent(x))
    return x


# --------------------------------------------------------------------------------------
# Whole files written by libraries (ezdxf, OpenCASCADE), put at the stated precision.

def _dxf_float_exponent(code: int) -> int | None:
    """The precision of a DXF group code's value, or None when the code is not a float."""
    if 10 <= code <= 39 or 110 <= code <= 139 or 210 <= code <= 239 or 1010 <= code <= 1039:
        return LENGTH_MM  # points, vectors: mm (or unit vectors, held to 1e-9 too)
    if 40 <= code <= 48 or 140 <= code <= 149 or 460 <= code <= 469 or 1040 <= code <= 1042:
        return LENGTH_MM  # lengths, radii, scale factors, knots, weights
    if code == 49:
        return LENGTH_MM
    if 50 <= code <= 58:
        return ANGLE_DEG  # angles in degrees
    return None


def dxf_text(text: str) -> str:
    """A DXF (tag stream: a group code line, then its value line) with every float value
    rewritten at its precision (`_dxf_float_exponent`); anything else untouched."""
    lines = text.split("\n")
    for i in range(0, len(lines) - 1, 2):
        code = lines[i].strip()
        if not code.lstrip("-").isdigit():
            continue
        exp = _dxf_float_exponent(int(code))
        if exp is None:
            continue
        try:
            value = float(lines[i + 1])
        except ValueError:
            continue
        lines[i + 1] = fmt(value, exp)
    return "\n".join(lines)


# A quoted STEP string ('' escapes a quote), or a REAL (a decimal point, optional exponent).
_STEP_TOKEN = re.compile(r"'(?:[^']|'')*'|(?<![\w#.])([-+]?\d+\.\d*(?:[Ee][-+]?\d+)?)")
_STEP_DIRECTION = re.compile(r"=\s*DIRECTION\s*\(")


def step_text(text: str) -> str:
    """A STEP file (ISO 10303-21) with every REAL of its DATA section at its precision:
    mm (1e-9) for coordinates, radii, knots and weights; ratio (1e-12) for the components
    of a DIRECTION. Strings, integers and entity references are untouched."""
    head, sep, data = text.partition("DATA;")
    if not sep:
        return text

    def real(m: re.Match, exp: int) -> str:
        if m.group(1) is None:
            return m.group(0)
        # ISO 10303-21 REALs in OCC's own style: "0.", "2.5", "1.5E-10".
        mantissa, e, power = fmt(float(m.group(1)), exp).partition("e")
        if mantissa.endswith(".0"):
            mantissa = mantissa[:-1]
        return mantissa + ("E" + power if e else "")

    out = []
    for entity in data.split(";"):
        exp = RATIO if _STEP_DIRECTION.search(entity) else LENGTH_MM
        out.append(_STEP_TOKEN.sub(lambda m: real(m, exp), entity))
    return head + sep + ";".join(out)
