"""`lathe-mirror measure`: a measured trace read in every format, fitted against the design.

The traces are built here from the hyperbola in closed form (each lobe the upper sheet
z = e + a sqrt(1 + r^2 / b^2), the machine frame Z = vertex - z), not from the tool's
made-surface code: a known decentre, tilt and piston, a smooth residual of a few um, noise
and a few spikes, sampled at a uniform x as an instrument does. Each format is written by
its own library where one writes it (x3pio for .x3p, surfalize for .sur, h5py for Zygo's
.datx layout as prysm reads it); the fit must find the decentre within 2 um, the tilt
within 2 urad and each lobe's residual within 15 % of its RMS. Zygo's binary .dat is read
only (prysm writes no .dat).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from conftest import run_cli
from lathe_mirror.measure.fit import fit_trace, profile_through_axis
from lathe_mirror.measure.readers import read_measurement

DECENTRE_MM, TILT_RAD, PISTON_MM = 0.137, 3.0e-4, 1.234
NOISE_MM = 5e-5
DX_MM = 0.005


@pytest.fixture(scope="module")
def case(design_case):
    return design_case


def design_machine_z(mirror, r):
    """The design in the machine frame from the hyperbola's closed form (test's own)."""
    i, o = mirror.inner, mirror.outer
    zi = i.e + i.a * np.sqrt(1 + r ** 2 / i.b ** 2)
    zo = o.e + o.a * np.sqrt(1 + r ** 2 / o.b ** 2)
    return (i.e + i.a) - np.where(r <= mirror.r_junction, zi, zo)


def smooth_residual(mirror, r):
    """A few um of smooth form error (mm)."""
    return 2e-3 * np.cos(2 * np.pi * r / 7.0) + 1.5e-3 * (r / mirror.r_max) ** 2


def part_row(mirror, u, v=0.0):
    """Height of the part (machine frame) at signed radius u, off the trace line by v."""
    r = np.hypot(u, v)
    return design_machine_z(mirror, r) + smooth_residual(mirror, r)


def trace_of(mirror, *, v=0.0, dx=DX_MM, seed=1):
    """Sampled at uniform x as an instrument does: the part turned by the tilt and moved
    by decentre and piston, then noise and three spikes."""
    u = np.linspace(-mirror.r_max, mirror.r_max, 400001)
    w = part_row(mirror, u, v)
    X = DECENTRE_MM + u * math.cos(TILT_RAD) - w * math.sin(TILT_RAD)
    Z = PISTON_MM + u * math.sin(TILT_RAD) + w * math.cos(TILT_RAD)
    x = np.arange(X.min() + 0.01, X.max() - 0.01, dx)
    z = np.interp(x, X, Z)
    rng = np.random.default_rng(seed)
    z = z + rng.normal(0.0, NOISE_MM, x.size)
    for i in rng.integers(0, x.size, 3):
        z[i] += 0.02  # dust: 20 um spikes
    return x, z


def assert_fit(fit, mirror, x_origin=0.0):
    assert abs(fit.decentre_mm - (DECENTRE_MM - x_origin)) < 2e-3
    assert abs(fit.tilt_rad - TILT_RAD) < 2e-6
    assert len(fit.lobes) == 2
    for lf in fit.lobes:
        g = np.linspace(lf.r_lo, lf.r_hi, 2001)
        true = smooth_residual(mirror, g)
        true = true - true.mean()
        got = fit.residual_at(g)
        got = got - got.mean()
        rms = float(np.sqrt(np.mean(true ** 2)))
        assert float(np.sqrt(np.mean((got - true) ** 2))) < 0.15 * rms, lf.name
        assert abs(lf.rms_um * 1e-3 - rms) < 0.15 * rms, lf.name
        slope = np.gradient(true, g)
        assert abs(lf.slope_rms_urad * 1e-6 - np.sqrt(np.mean(slope ** 2))) < 0.15 * np.sqrt(np.mean(slope ** 2))


def write_csv(path, x, z):
    np.savetxt(path, np.c_[x * 1e3, z * 1e3], delimiter=",", header="x [um],z [um]", comments="", fmt="%.6f")


def write_prf(path, z, dx):
    """Taylor Hobson's ASCII layout (the NPL reference files): heights in um x 1e-6 m."""
    head = ["1 2", "LM 0.000000e+000 PRF", f"CX M {z.size:.6e} MM 1.000000e+000 D",
            f"CZ M {z.size:.6e} UM 1.000000e-006 L", "EOR", "STYLUS_RADIUS 0.000000e+000 MM",
            f"SPACING MM {dx:.9e}", "MAP 1.0e+000 CZ CX 1.0e+000 0 0", "EOR"]
    path.write_text("\n".join(head + [f"{v:.6f}" for v in z * 1e3] + ["EOR", ""]), encoding="ascii")


def test_csv_prf_x3p_round_trip(case):
    import x3pio

    m, d = case["mirror"], case["dir"]
    x, z = trace_of(m)
    write_csv(d / "t.csv", x, z)
    write_prf(d / "t.prf", z, DX_MM)
    x3pio.write(d / "t.x3p", z * 1e-3, x_scale=DX_MM * 1e-3)
    for name, origin in (("t.csv", 0.0), ("t.prf", x[0]), ("t.x3p", x[0])):
        tr = read_measurement(d / name)
        assert tr.x.size == x.size
        assert_fit(fit_trace(tr, m), m, origin)


def areal_map(mirror, dy=0.05, rows=31):
    """A strip of rows about the axis (y0 between rows), each row a trace."""
    y0 = 0.0137
    ys = (np.arange(rows) - rows // 2) * dy
    zz = []
    for j, y in enumerate(ys):
        x, z = trace_of(mirror, v=y - y0, dx=0.01, seed=10 + j)
        zz.append(z)
    n = min(len(z) for z in zz)
    return x[:n], ys, np.array([z[:n] for z in zz])


def test_areal_maps_sur_x3p_datx(case):
    import h5py
    import surfalize
    import x3pio

    m, d = case["mirror"], case["dir"]
    x, ys, Z = areal_map(m)
    surfalize.Surface(Z * 1e3, 10.0, 50.0).save(d / "m.sur")  # um
    x3pio.write(d / "m.x3p", Z * 1e-3, x_scale=1e-5, y_scale=5e-5)
    # Zygo MX's .datx layout, as prysm.io.read_zygo_datx reads it (heights nm; square pixels)
    _, _, Zsq = areal_map(m, dy=0.01)
    with h5py.File(d / "m.datx", "w") as f:
        s = f.create_group("Data").create_group("Surface").create_dataset("{0}", data=Zsq * 1e6)
        s.attrs["No Data"] = np.array([1e38])
        s.attrs["Wavelength"] = np.array([632.8e-9])
        s.attrs["Unit"] = np.array([b"NanoMeters"])
        s.attrs["Interferometric Scale Factor"] = np.array([0.5])
        s.attrs["Obliquity Factor"] = np.array([1.0])
        a = f.create_group("Attributes").create_group("{1}")
        a.attrs["Data Context.Lateral Resolution:Value"] = np.array([1e-5])
    for name, dy in (("m.sur", 0.05), ("m.x3p", 0.05), ("m.datx", 0.01)):
        area = read_measurement(d / name)
        assert area.z.shape == Z.shape
        assert np.allclose(np.diff(area.y), dy) and np.allclose(np.diff(area.x), 0.01)
        tr = profile_through_axis(area, m)
        assert_fit(fit_trace(tr, m), m, x[0])


def test_cli_json_and_files(case, tmp_path):
    m = case["mirror"]
    x, z = trace_of(m)
    write_csv(tmp_path / "t.csv", x, z)
    args = ["measure", str(tmp_path / "t.csv"), "--json", "-o", str(tmp_path / "out")]
    if case["cfg"]:
        args += ["--config", str(case["cfg"])]
    p = run_cli(*args)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert abs(out["fit"]["decentre_mm"] - DECENTRE_MM) < 2e-3
    assert abs(out["fit"]["tilt_rad"] - TILT_RAD) < 2e-6
    assert abs(out["fit"]["piston_mm"] - PISTON_MM) < 5e-3
    assert [lf["name"] for lf in out["lobes"]] == ["inner", "outer"]
    assert all({"pv_um", "rms_um", "slope_rms_urad"} <= set(lf) for lf in out["lobes"])
    assert {"nose_radius_error_mm", "centre_height_mm", "x_offset_mm", "backlash_mm"} <= set(out["diagnosis"])
    # a smooth form error is not a set-up error
    assert out["diagnosis"]["centre_height_mm"] == 0.0 and out["diagnosis"]["nose_radius_error_mm"] == 0.0
    # each lobe judged against the form tolerance `lathe-mirror spec` states for it
    sp = run_cli("spec", "--json", *(["--config", str(case["cfg"])] if case["cfg"] else []))
    assert sp.returncode == 0, sp.stderr
    forms = {lb["name"]: lb["form_tolerance"] for lb in json.loads(sp.stdout)["lobes"]}
    for lf, v in zip(out["lobes"], out["form_tolerance"]):
        f = forms[lf["name"]]
        assert v["name"] == lf["name"] and v["rms_um"] == f["rms_um"]
        assert v["pass"] == (lf["pv_um"] <= f["pv_um"] and lf["rms_um"] <= f["rms_um"]
                             and lf["slope_rms_urad"] <= f["slope_urad"])
    assert (tmp_path / "out" / "measure.json").is_file()
    assert (tmp_path / "out" / "measured_minus_design.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("name,content,phrase", [
    ("bad.x3p", b"x,z\n1,2\n", "not a readable x3p file"),
    ("bad.prf", b"1 2\nCZ M 3 UM 1e-6 L\n1\n2\n", "two EOR"),
    ("bad.datx", b"not hdf5", "not a readable datx file"),
    ("bad.sur", b"\x00" * 64, "not a readable surfalize file"),
    ("bad.csv", b"x_mm,z_mm\n1,2\n3,abc\n", "not two numbers"),
    ("short.csv", b"x_mm,z_mm\n1,2\n3,4\n", "at least 50"),
    ("bad.xyzzy", b"1,2\n", "unknown measurement suffix"),
])
def test_file_not_what_it_says(tmp_path, name, content, phrase):
    (tmp_path / name).write_bytes(content)
    p = run_cli("measure", str(tmp_path / name))
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and phrase in lines[0] and "Traceback" not in p.stderr


def test_not_a_regular_file(tmp_path):
    (tmp_path / "d.csv").mkdir()
    p = run_cli("measure", str(tmp_path / "d.csv"))
    assert p.returncode == 2 and "is a directory" in p.stderr and len(p.stderr.strip().splitlines()) == 1


class _ClosedForm:
    """The test's own made surface: design minus the smooth residual, camera frame (the
    residual is in the machine frame, Z = vertex - z)."""

    def __new__(cls, mirror):
        from lathe_mirror.profile import Profile

        class P(Profile):
            def z(self, r):
                r = np.asarray(r, float)
                i, o = mirror.inner, mirror.outer
                zz = np.where(r <= mirror.r_junction, i.e + i.a * np.sqrt(1 + r ** 2 / i.b ** 2),
                              o.e + o.a * np.sqrt(1 + r ** 2 / o.b ** 2))
                return zz - smooth_residual(mirror, r)

            def slope(self, r):
                r = np.asarray(r, float)
                i, o = mirror.inner, mirror.outer
                s = np.where(r <= mirror.r_junction, i.a * r / (i.b ** 2 * np.sqrt(1 + r ** 2 / i.b ** 2)),
                             o.a * r / (o.b ** 2 * np.sqrt(1 + r ** 2 / o.b ** 2)))
                ds = -2e-3 * 2 * np.pi / 7.0 * np.sin(2 * np.pi * r / 7.0) + 2 * 1.5e-3 * r / mirror.r_max ** 2
                return s - ds

        return P(r_junction=mirror.r_junction, r_max=mirror.r_max, vertex_z=mirror.inner.e + mirror.inner.a)


def test_measured_surface_images_as_the_part(case):
    """The measured part as a surface (--surface measured:FILE's profile) sends the camera's
    rays where the test's closed-form part does: image displacement and ray deviation per
    lobe within 15 % (and a few hundredths of a pixel) of the closed form's."""
    from lathe_mirror.measure.surface import measured_profile
    from lathe_mirror.optics.radial import radial_figures

    m, d = case["mirror"], case["dir"]
    x, z = trace_of(m)
    write_csv(d / "s.csv", x, z)
    got = radial_figures(measured_profile(d / "s.csv", m, nose_radius_mm=0.2), m)["lobes"]
    want = radial_figures(_ClosedForm(m), m)["lobes"]
    for g, w in zip(got, want):
        for key in ("image_displacement_px", "ray_deviation_deg"):
            assert abs(g[key]["rms"] - w[key]["rms"]) < 0.15 * w[key]["rms"] + (0.03 if key.endswith("px") else 1e-3), \
                (g["name"], key, g[key], w[key])


def test_commands_take_measured_surface(case, tmp_path):
    m = case["mirror"]
    x, z = trace_of(m)
    write_csv(tmp_path / "s.csv", x, z)
    cfg = ["--config", str(case["cfg"])] if case["cfg"] else []
    p = run_cli("render", "--surface", f"measured:{tmp_path / 's.csv'}", "--json", "--no-progress", *cfg)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["surface"] == "measured" and len(out["lobes"]) == 2
    p = run_cli("calib", "--surface", f"measured:{tmp_path / 's.csv'}", "-o", str(tmp_path / "calib"),
                "--no-progress", *cfg)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "calib" / "opencv_inner.yaml").is_file()
    p = run_cli("render", "--surface", "measured:", *cfg)
    assert p.returncode == 2 and "measured:FILE" in p.stderr


def test_report_surface_takes_only_a_measured_part(tmp_path):
    p = run_cli("report", "--surface", "paper", "-o", str(tmp_path / "r"))
    assert p.returncode == 2 and "report takes measured:FILE" in p.stderr
    assert not (tmp_path / "r").exists()
