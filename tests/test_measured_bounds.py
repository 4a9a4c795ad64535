"""Measured files that lie: each refused with one line naming the file and the field, exit 2,
within a time bound (and the bombs within a memory bound, in a process of their own under
RLIMIT_AS), before the lie is inflated or followed.

The hostile files are built here, small: a .datx whose dataset is stored in another file
(and in /dev/zero), a virtual dataset, external and soft links, a dataset declaring 10^10
points in a few KB; an .x3p whose data member inflates to 64 MiB of zeros, whose main.xml
does, whose main.xml declares a 10^10-point grid; CSV, .prf, .x3p and .datx with
heights or spacings that are infinite or beyond any part; a CSV of 12 million rows.
The limits (bounds.MAX_COORD_MM, MAX_TRACE_POINTS, LATHE_MIRROR_MAX_GIB) are stated in
lathe_mirror/measure/bounds.py; the numbers each test expects in a message are computed
here from the file the test wrote.
"""

from __future__ import annotations

import io
import os
import resource
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

from conftest import run_cli

#: Seconds any refusal may take (the reads they replace ran 26 to 272 s).
TIME_BOUND_S = 10.0
#: Address space of a process that reads a bomb (the bombs reached 6.2 GB).
MEMORY_BOUND = 3 << 30


def refused(args, *, phrases, env=None, fresh=False):
    """Run `lathe-mirror ARGS`: exit 2, one line, every phrase in it, within the time bound."""
    t0 = time.monotonic()
    p = (run_bounded(args, env) if fresh else run_cli(*args, env=env))
    elapsed = time.monotonic() - t0
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, (args, p.returncode, p.stderr[-2000:])
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    for phrase in phrases:
        assert phrase in lines[0], (phrase, lines[0])
    assert elapsed < TIME_BOUND_S + (5.0 if fresh else 0.0), (args, elapsed)
    return lines[0]


def run_bounded(args, env=None):
    """In a new interpreter whose address space is MEMORY_BOUND: a read that inflated the
    bomb would fail there with MemoryError (exit 1), not pass."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BOUND, MEMORY_BOUND))

    e = dict(os.environ if env is None else env)
    e["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
    e.setdefault("OPENBLAS_NUM_THREADS", "1")
    return subprocess.run([sys.executable, "-m", "lathe_mirror", *args], capture_output=True, text=True,
                          env=e, preexec_fn=limit, timeout=120)


# --------------------------------------------------------------------------------------
# .datx (HDF5)


def zygo_datx(path: Path, *, z_nm=None, resolution_m=1e-5, **dataset):
    """Zygo MX's layout as prysm.io.read_zygo_datx reads it; the surface dataset made with
    `dataset` (h5py.create_dataset's arguments) or holding z_nm."""
    import h5py

    with h5py.File(path, "w") as f:
        g = f.create_group("Data").create_group("Surface")
        s = g.create_dataset("{0}", data=z_nm) if z_nm is not None else g.create_dataset("{0}", **dataset)
        s.attrs["No Data"] = np.array([1e38])
        s.attrs["Wavelength"] = np.array([632.8e-9])
        s.attrs["Unit"] = np.array([b"NanoMeters"])
        s.attrs["Interferometric Scale Factor"] = np.array([0.5])
        s.attrs["Obliquity Factor"] = np.array([1.0])
        a = f.create_group("Attributes").create_group("{1}")
        a.attrs["Data Context.Lateral Resolution:Value"] = np.array([resolution_m])
    return path


def test_datx_stored_in_another_file_is_refused(tmp_path):
    other = tmp_path / "other.bin"
    np.full((200, 200), 5.0).tofile(other)
    d = zygo_datx(tmp_path / "ext.datx", shape=(200, 200), dtype="f8", external=[(str(other), 0, 200 * 200 * 8)])
    assert d.stat().st_size < 10_000
    refused(["measure", str(d)], phrases=["ext.datx", "{0}", "another file", "other.bin"])
    z = zygo_datx(tmp_path / "zero.datx", shape=(60_000, 60_000), dtype="f8",
                  external=[("/dev/zero", 0, 60_000 * 60_000 * 8)])
    refused(["measure", str(z)], phrases=["zero.datx", "/dev/zero"], fresh=True)


def test_datx_virtual_dataset_and_links_out_are_refused(tmp_path):
    import h5py

    src = tmp_path / "src.h5"
    with h5py.File(src, "w") as f:
        f["z"] = np.zeros((100, 100))
    layout = h5py.VirtualLayout(shape=(100, 100), dtype="f8")
    layout[:] = h5py.VirtualSource(str(src), "z", shape=(100, 100))
    v = tmp_path / "virtual.datx"
    zygo_datx(v, z_nm=np.zeros((100, 100)))
    with h5py.File(v, "a") as f:
        f["Data"].create_virtual_dataset("Mapped", layout)
    refused(["measure", str(v)], phrases=["virtual.datx", "Data/Mapped", "virtual"])

    for kind, link in (("external", lambda: h5py.ExternalLink(str(src), "z")),
                       ("soft", lambda: h5py.SoftLink("/Data/Surface/{0}"))):
        p = zygo_datx(tmp_path / f"{kind}.datx", z_nm=np.zeros((100, 100)))
        with h5py.File(p, "a") as f:
            f["Data/Surface"]["{9}"] = link()
        refused(["measure", str(p)], phrases=[f"{kind}.datx", "Data/Surface/{9}",
                                              "another file" if kind == "external" else "soft link"])


def test_datx_declaring_more_than_memory_is_refused_before_reading(tmp_path):
    """10^10 float64 points declared in a chunked, compressed dataset never written: the file
    is a few KB, reading it would allocate 80 GB."""
    d = zygo_datx(tmp_path / "bomb.datx", shape=(100_000, 100_000), dtype="f8", chunks=(1000, 1000),
                  compression="gzip")
    assert d.stat().st_size < 20_000
    need_gib = (100_000 ** 2 * 8 + 100_000 ** 2 * 64) / 2 ** 30  # the data and its working memory
    line = refused(["measure", str(d)], phrases=["bomb.datx", "10000000000 points", "LATHE_MIRROR_MAX_GIB",
                                                  f"{need_gib:.3g} GiB"], fresh=True)
    assert "limit 8 GiB" in line


def test_the_memory_limit_comes_from_the_environment(tmp_path, monkeypatch):
    """A real 300 x 400 map (0.96 MB of float64, 7.7 MB of working memory at 64 B a point)
    passes at the default limit and is refused at LATHE_MIRROR_MAX_GIB = 0.005 (5.4 MB), as
    .datx and as .x3p. (The commands refuse their own work at such a limit before reading.)"""
    from lathe_mirror.errors import InputError
    from lathe_mirror.measure.readers import read_measurement

    yy, xx = np.mgrid[0:300, 0:400] * 1e-2
    z_mm = 1.0 - 0.01 * (xx - 2.0) ** 2 - 0.01 * (yy - 1.5) ** 2
    d = zygo_datx(tmp_path / "m.datx", z_nm=1e6 * z_mm)
    x = tmp_path / "m.x3p"
    x.write_bytes(_x3p_bytes(z_mm * 1e-3, x_scale=1e-5, y_scale=1e-5))
    for p in (d, x):
        assert np.allclose(read_measurement(p).z, z_mm)
    monkeypatch.setenv("LATHE_MIRROR_MAX_GIB", "0.005")
    for p in (d, x):
        with pytest.raises(InputError) as e:
            read_measurement(p)
        line = str(e.value)
        assert "\n" not in line and p.name in line and "120000 points" in line and "limit 0.005 GiB" in line
    monkeypatch.setenv("LATHE_MIRROR_MAX_GIB", "lots")
    with pytest.raises(InputError, match="LATHE_MIRROR_MAX_GIB = 'lots': allowed a number > 0"):
        read_measurement(d)


# --------------------------------------------------------------------------------------
# .x3p (zip)


def _x3p_bytes(z_m, **kw) -> bytes:
    import x3pio

    buf = io.BytesIO()
    x3pio.write(buf, z_m, **kw)
    return buf.getvalue()


def _rezip(data: bytes, replace: dict[str, bytes]) -> bytes:
    """The archive with the named members' content replaced (deflated)."""
    src = zipfile.ZipFile(io.BytesIO(data))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for info in src.infolist():
            z.writestr(info.filename, replace.get(info.filename, src.read(info.filename)))
    return out.getvalue()


def test_x3p_zip_bombs_are_refused_before_inflating(tmp_path):
    good = _x3p_bytes(np.zeros((20, 30)), x_scale=1e-6, y_scale=1e-6)
    zeros = bytes(64 << 20)
    bomb = tmp_path / "bomb.x3p"
    bomb.write_bytes(_rezip(good, {"bindata/data.bin": zeros}))
    assert bomb.stat().st_size < 200_000
    allowed = 20 * 30 * 25 + (32 << 20)  # the grid as float64 x, y, z with validity bits, and 32 MiB
    refused(["measure", str(bomb)], phrases=["bomb.x3p", "bindata/data.bin", f"{64 << 20}", f"{allowed}"],
            fresh=True)

    xml = zipfile.ZipFile(io.BytesIO(good)).read("main.xml")
    padded = xml.replace(b"<Record2>", b"<!--" + b" " * (40 << 20) + b"--><Record2>")
    p = tmp_path / "xml.x3p"
    p.write_bytes(_rezip(good, {"main.xml": padded}))
    refused(["measure", str(p)], phrases=["xml.x3p", "main.xml", f"{len(padded)}", f"{32 << 20}"])

    huge = xml.replace(b"<SizeX>30</SizeX>", b"<SizeX>100000</SizeX>").replace(b"<SizeY>20</SizeY>",
                                                                               b"<SizeY>100000</SizeY>")
    p = tmp_path / "grid.x3p"
    p.write_bytes(_rezip(good, {"main.xml": huge}))
    refused(["measure", str(p)], phrases=["grid.x3p", "10000000000 points", "LATHE_MIRROR_MAX_GIB"])


# --------------------------------------------------------------------------------------
# Numbers that are not finite, or not the size of a part


def _trace(n=400):
    x = np.linspace(-30.0, 30.0, n)
    return x, 0.01 * x ** 2


def test_huge_and_infinite_coordinates_are_refused_naming_the_field(tmp_path):
    x, z = _trace()
    for label, value, shown in (("big", 1e300, "1e+300"), ("inf", 1e400, "inf"), ("past", 2e4, "20000")):
        zz = z.copy()
        zz[7] = value
        p = tmp_path / f"{label}.csv"
        p.write_text("x_mm,z_mm\n" + "\n".join(f"{a!r},{b!r}" for a, b in zip(x.tolist(), zz.tolist())) + "\n")
        refused(["measure", str(p)], phrases=[f"{label}.csv", f"z = {shown} mm", "point 7", "10000 mm"])
    # .prf: heights x the CZ scale (1e-6 m: 1e-3 mm)
    p = tmp_path / "big.prf"
    p.write_text("HEADER\nCZ M 3 UM 1.0e-6 L\nSPACING MM 0.1\nEOR\nEOR\n" + "\n".join(["1e305"] * 100) + "\nEOR\n")
    refused(["measure", str(p)], phrases=["big.prf", "z = 1e+302 mm", "point 0"])
    p = tmp_path / "spacing.prf"
    p.write_text("HEADER\nCZ M 3 UM 1.0e-6 L\nSPACING MM inf\nEOR\nEOR\n" + "\n".join(["1"] * 100) + "\nEOR\n")
    refused(["measure", str(p)], phrases=["spacing.prf", "SPACING = inf mm"])
    # .x3p: heights of 1e300 m
    p = tmp_path / "big.x3p"
    p.write_bytes(_x3p_bytes(np.full(300, 1e300), x_scale=1e-5))
    refused(["measure", str(p)], phrases=["big.x3p", "z = 1e+303 mm"])
    # .datx: an infinite lateral resolution, and a zero one
    for label, res in (("inf", np.inf), ("zero", 0.0)):
        d = zygo_datx(tmp_path / f"res_{label}.datx", z_nm=np.zeros((60, 80)), resolution_m=res)
        refused(["measure", str(d)], phrases=[f"res_{label}.datx", "Lateral Resolution", "> 0"])


def test_a_csv_past_the_point_budget_is_refused_at_once(tmp_path):
    """12 million rows (48 MB, under the 256 MiB file limit; the read it replaces took 272 s
    and 5.46 GB for 232 MB) refused on its line count before a row is split."""
    from lathe_mirror.measure.bounds import MAX_TRACE_POINTS

    p = tmp_path / "long.csv"
    p.write_bytes(b"1,2\n" * 12_000_000)
    refused(["measure", str(p)], phrases=["long.csv", "12000001 lines", f"{MAX_TRACE_POINTS} points"], fresh=True)
    ok = tmp_path / "ok.csv"
    x = np.linspace(-30.0, 30.0, 1000)
    ok.write_text("\n".join(f"{a!r} {0.01 * a * a!r} 7" for a in x.tolist()))  # whitespace, a third column ignored
    from lathe_mirror.measure.readers import read_measurement

    t = read_measurement(ok)
    assert np.allclose(t.x, x) and np.allclose(t.z, 0.01 * x ** 2)


# --------------------------------------------------------------------------------------
# --surface measured: every command that takes it


@pytest.mark.parametrize("command", ["tolerance", "calib", "render", "report", "stereo"])
def test_surface_measured_without_a_file_and_with_a_lying_one(command, tmp_path):
    refused([command, "--surface", "measured", "-o", str(tmp_path / "o")], phrases=["--surface measured",
                                                                                      "measured:FILE"])
    assert not (tmp_path / "o").exists()
    if command in ("report", "stereo"):
        return
    x, z = _trace()
    z[3] = 1e300
    p = tmp_path / "big.csv"
    p.write_text("\n".join(f"{a!r},{b!r}" for a, b in zip(x.tolist(), z.tolist())))
    refused([command, "--surface", f"measured:{p}", "-o", str(tmp_path / "o"), "--no-progress"],
            phrases=["big.csv", "z = 1e+300 mm"])
    assert not (tmp_path / "o").exists()


def test_a_zipped_areal_format_is_bounded_too(tmp_path, monkeypatch):
    """surfalize's zip containers (.plux here) are held to the memory limit by their
    members' declared sizes: 16 MiB of zeros x 8 (float64 working memory: 0.125 GiB)
    against a limit of 0.1 GiB is refused before surfalize inflates it."""
    from lathe_mirror.errors import InputError
    from lathe_mirror.measure.readers import read_measurement

    p = tmp_path / "bomb.plux"
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("LAYER_0.raw", bytes(16 << 20))
        z.writestr("index.xml", b"<xml/>")
    monkeypatch.setenv("LATHE_MIRROR_MAX_GIB", "0.1")
    with pytest.raises(InputError, match=r"bomb.plux .*LAYER_0.raw.*0.125 GiB.*limit 0.1 GiB"):
        read_measurement(p)


# --------------------------------------------------------------------------------------
# .zon (Keyence: a zip behind a preview image, its members zstd frames that declare no size)


def _zon_bytes(members: dict[str, bytes]) -> bytes:
    """A Keyence .zon as surfalize's reader (and Gwyddion's zonfile.c) lays it out: an
    8-byte "KPK" block, a BMP whose header states its size (here only its 14-byte file
    header), then the zip of `members` (stored: the members' own bytes, zstd or not)."""
    import struct

    bmp = b"BM" + struct.pack("<IHHI", 14, 0, 0, 14)
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_STORED) as z:
        for name, content in members.items():
            z.writestr(name, content)
    return b"KPK\x00\x00\x00\x00\x00" + bmp + out.getvalue()


def _zstd_zeros(nbytes: int) -> bytes:
    """One zstd frame of `nbytes` zeros (a multiple of 128 KiB) that declares no content
    size, written from the format's definition (RFC 8878): the magic 0xFD2FB528, a frame
    header descriptor of 0 (no content size, no checksum, not single-segment), a window
    descriptor of 0x38 (exponent 7: a 2^17 = 128 KiB window), then RLE blocks of the
    largest size, 128 KiB: a 3-byte little-endian header (last-block bit, type 1 = RLE in
    bits 1-2, the size in bits 3-23) and the one byte repeated. 4 bytes per 128 KiB."""
    block = 128 << 10
    assert nbytes % block == 0
    n = nbytes // block
    head = (1 << 1 | block << 3).to_bytes(3, "little") + b"\x00"
    last = (1 | 1 << 1 | block << 3).to_bytes(3, "little") + b"\x00"
    return b"\x28\xb5\x2f\xfd\x00\x38" + head * (n - 1) + last


ZON_XML = (b"<Calibration><XYCalibration><MeterPerPixel>1e-05</MeterPerPixel></XYCalibration>"
           b"<ZCalibration><MeterPerUnit>1e-09</MeterPerUnit></ZCalibration></Calibration>")


def test_a_zon_reads_back_and_its_zstd_bomb_is_refused(tmp_path, monkeypatch):
    """A real .zon: a 30 x 40 height map of int32 nm (10 um pixels) behind the 16-byte
    header (x, y, item size 4, row stride), zstd-compressed without a declared size, reads
    back in mm. The same file with the heights' member replaced by 64 MiB of zeros in a
    256-byte zstd frame is refused at LATHE_MIRROR_MAX_GIB = 0.1 GiB, before surfalize
    inflates it: 0.1 GiB / 8 bytes of float64 working memory per inflated byte =
    13421772 bytes allowed."""
    import struct

    import zstandard

    from lathe_mirror.errors import InputError
    from lathe_mirror.measure.readers import read_measurement

    yy, xx = np.mgrid[0:30, 0:40]
    z_nm = (1000 * (xx - 20) ** 2 // 10 + 50 * yy).astype("<i4")
    body = struct.pack("<IIII", 40, 30, 4, 40 * 4) + z_nm.tobytes()
    c = zstandard.ZstdCompressor().compressobj()
    frame = c.compress(body) + c.flush()
    assert zstandard.frame_content_size(frame) == -1  # no size declared, as Keyence writes them
    good = tmp_path / "good.zon"
    good.write_bytes(_zon_bytes({"calib.xml": ZON_XML, "height.bin": frame}))
    m = read_measurement(good)
    assert np.allclose(m.z, z_nm * 1e-6) and np.allclose(np.diff(m.x), 0.01) and np.allclose(np.diff(m.y), 0.01)

    bomb = _zstd_zeros(64 << 20)
    assert len(bomb) == 6 + 4 * 512
    p = tmp_path / "bomb.zon"
    p.write_bytes(_zon_bytes({"calib.xml": ZON_XML, "height.bin": bomb}))
    monkeypatch.setenv("LATHE_MIRROR_MAX_GIB", "0.1")
    allowed = int(0.1 * 2**30) // 8
    assert allowed == 13421772
    with pytest.raises(InputError, match=rf"bomb.zon .*'height.bin' is a zstd stream that inflates to at least "
                                         rf"\d+ bytes, the members together past the {allowed} bytes.*limit of 0.1 GiB"):
        read_measurement(p)
    monkeypatch.delenv("LATHE_MIRROR_MAX_GIB")
    assert read_measurement(good).z.shape == (30, 40)  # the default limit reads the real one


def test_a_zon_bomb_beyond_the_default_limit_is_refused_within_the_memory_bound(tmp_path):
    """4 GiB of zeros in a 128 KiB zstd frame (surfalize would inflate it whole: past the
    3 GiB address space of the reading process) refused by `measure` at the default 8 GiB
    limit (1 GiB inflated, 8 bytes of working memory each), counted a chunk at a time,
    within the time bound, one line."""
    p = tmp_path / "bomb.zon"
    p.write_bytes(_zon_bytes({"calib.xml": ZON_XML, "height.bin": _zstd_zeros(4 << 30)}))
    assert p.stat().st_size < 200_000
    refused(["measure", str(p)], phrases=["bomb.zon", "'height.bin'", "zstd", f"{(8 << 30) // 8} bytes",
                                          "LATHE_MIRROR_MAX_GIB"], fresh=True)
