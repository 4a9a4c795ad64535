"""export/numbers.py: the stated precisions and the one formatter; a design moved by the
last bit of its floats writes the same bytes (calibration files, DXF, STEP, JSON)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from lathe_mirror.export.numbers import (ANGLE_DEG, LENGTH_MM, PIXEL, RATIO, dxf_text, fmt, fmt_sig,
                                         json_precise, polynomial_exponent, step_text)


@pytest.mark.parametrize("x, exp, text", [
    (0.1 + 0.2, LENGTH_MM, "0.3"),                     # 0.30000000000000004 at 1e-9
    (237.66846224748042, PIXEL, "237.668462"),
    (2.0, LENGTH_MM, "2.0"),
    (-0.0, LENGTH_MM, "0.0"),
    (-4e-10, LENGTH_MM, "0.0"),                        # below the precision: no "-0.0"
    (1.6e-9, LENGTH_MM, "0.000000002"),
    (1.5e-9, LENGTH_MM, "0.000000001"),              # the binary 1.5e-9 is 1.4999...e-9
    (0.991023401485123, RATIO, "0.991023401485"),
    (2.520392490667e-17, -23, "2.520392e-17"),         # finer than 1e-12: scientific
    (1e20, LENGTH_MM, "1.0e+20"),
    (-119.36999725264, -8, "-119.36999725"),
])
def test_fmt_hand_values(x, exp, text):
    assert fmt(x, exp) == text


def test_fmt_refuses_non_finite():
    for bad in (math.nan, math.inf):
        with pytest.raises(ValueError, match="non-finite"):
            fmt(bad, LENGTH_MM)


def test_fmt_sig_and_polynomial_precision():
    assert fmt_sig(20.123456789012345) == "20.123456789"
    assert fmt_sig(-1e-7) == "-1.0e-07"
    # a_4 rho^4 to 1e-6 px at rho 500 px: 500^4 = 6.25e10, so a_4 to 1e-17 (ceil(4 log10 500) = 11)
    assert polynomial_exponent(4, 500.0, PIXEL) == -17


def test_json_precise_by_unit_suffix():
    data = {"normal_deviation_mm": {"rms": 1.23456789012345e-7, "max": 0.1 + 0.2},
            "angles_deg": [1 / 3], "at_2_m": {"exact": {"rms": 3.5019305769201817e-10}},
            "trials": 1000, "yield": 0.123456789012345678, "name": "inner", "ok": True}
    got = json_precise(data)
    assert got["normal_deviation_mm"] == {"rms": 1.23e-7, "max": 0.3}
    assert got["angles_deg"] == [0.3333333333]                       # 1e-10 deg
    assert got["at_2_m"]["exact"]["rms"] == 3.50193057692e-10        # a range, not a unit
    assert got["yield"] == 0.123456789012 and got["trials"] == 1000
    assert got["name"] == "inner" and got["ok"] is True


def test_dxf_text_rewrites_float_codes_only():
    text = "  0\nLINE\n  5\n1F\n  8\nBODY\n 10\n0.30000000000000004\n 20\n-1e-12\n 50\n89.99999999999999\n 70\n1\n"
    assert dxf_text(text) == "  0\nLINE\n  5\n1F\n  8\nBODY\n 10\n0.3\n 20\n0.0\n 50\n90.0\n 70\n1\n"


def test_step_text_rewrites_reals_only():
    text = ("ISO-10303-21;\nHEADER;\nFILE_NAME('a 1.23456789012345','2020-01-01T00:00:00');\nENDSEC;\nDATA;\n"
            "#1 = CARTESIAN_POINT('1.0000000000001',(20.,0.,-11.92882986592));\n"
            "#2 = DIRECTION('',(9.746538860364E-05,-0.,0.99999999525));\n#3 = CIRCLE('',#1,14.989940679942);\n"
            "ENDSEC;\nEND-ISO-10303-21;\n")
    got = step_text(text)
    assert "FILE_NAME('a 1.23456789012345','2020-01-01T00:00:00')" in got  # the header is left alone
    assert "#1 = CARTESIAN_POINT('1.0000000000001',(20.,0.,-11.928829866));" in got  # strings too
    assert "#2 = DIRECTION('',(0.000097465389,0.,0.99999999525));" in got  # ratios to 1e-12
    assert "#3 = CIRCLE('',#1,14.98994068);" in got


def _nudged(mirror):
    """The mirror with every lobe float moved by one ulp: what another BLAS or CPU does."""
    def lobe(lb):
        return dataclasses.replace(lb, **{k: float(np.nextafter(getattr(lb, k), math.inf))
                                          for k in ("a", "b", "e", "h")})
    return dataclasses.replace(mirror, inner=lobe(mirror.inner), outer=lobe(mirror.outer))


def test_last_bit_changes_no_byte(paper_mirror):
    """A design moved by one ulp writes the same calibration files, DXF, STEP and JSON
    (figures recomputed from the nudged floats); the unrounded text would differ."""
    from lathe_mirror.body import BodySpec, design_meridian
    from lathe_mirror.design_table import design_figures
    from lathe_mirror.export.calib import calibration_texts
    from lathe_mirror.export.dxf import dxf_bytes
    from lathe_mirror.export.files import json_text
    from lathe_mirror.export.step import step_bytes

    nudged = _nudged(paper_mirror)
    assert nudged.inner.a != paper_mirror.inner.a
    assert calibration_texts(nudged) == calibration_texts(paper_mirror)
    raw = {"a": repr(paper_mirror.inner.a)}, {"a": repr(nudged.inner.a)}
    assert raw[0] != raw[1]  # the last bit shows without the stated precision
    assert json_text(design_figures(nudged)) == json_text(design_figures(paper_mirror))
    m0, m1 = design_meridian(paper_mirror, BodySpec()), design_meridian(nudged, BodySpec())
    assert dxf_bytes(nudged, m1) == dxf_bytes(paper_mirror, m0)
    assert step_bytes(m1) == step_bytes(m0)
    json.loads(json_text(design_figures(nudged)))  # and it is still JSON
