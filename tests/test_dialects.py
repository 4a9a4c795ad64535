"""The controls' dialects as objects (export/dialects): the Siemens 840D program read back
by the project's own replay moves exactly as LinuxCNC's rs274 reports the LinuxCNC
program's moves (1e-4 mm), and simulates to the same figures; the Fanuc offset list is in
Fanuc's programmable-data-input form; a dialect of a test's own, one class in this module,
is written, put on the set-up sheet, read back and taken by the command line."""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import run_cli
from lathe_mirror.config import load
from lathe_mirror.export.dialects import DIALECTS, Dialect, Measured, register, unregister
from lathe_mirror.export.gcode import format_program, offset_table, program_files, sheet_tools
from lathe_mirror.export.setup_sheet import setup_sheet_html
from lathe_mirror.path import Arc
from lathe_mirror.shop.programs import shop_program
from lathe_mirror.shop.replay import read_program
from lathe_mirror.shop.stock import simulate
from lathe_mirror.toolpath import plan_toolpath
from lathe_mirror.toolpath.moves import Hand
from test_gcode import canonical_moves, rs274


@pytest.fixture(scope="module")
def shop():
    """The paper default's arcs program with its part-off and second set-up."""
    settings = load()
    m = settings.mirror()
    tp = plan_toolpath(m, settings.machine, settings.tool, settings.toolpath.strategy)
    return settings, shop_program(tp, settings.stock, settings.toolpath, body=settings.body)


def test_siemens_program_replays_to_linuxcncs_moves(tmp_path, shop):
    """Every move of the Siemens program, read back by shop.replay through the Siemens
    dialect's translation, ends where rs274 (LinuxCNC's own interpreter, an independent
    reading) puts the LinuxCNC program's move of the same block, with the same kind (rapid,
    line, arc), block number and arc centre, to 1e-4 mm."""
    settings, sh = shop
    text = format_program(sh.program, "siemens")
    lines = text.splitlines()
    assert lines[0] == "%_N_MIRROR_ARCS_MPF" and "DIAMON" in lines and lines[-1].endswith("M30")
    assert re.search(r'^N\d+ T="T1" D1$', text, re.M) and re.search(r"^N\d+ LIMS=3000$", text, re.M)
    assert "G96 S200 M3" in lines and not any(ln.startswith("(") for ln in lines)
    mine = [mv for op in read_program(text, settings.machine, DIALECTS["siemens"]) for mv in op.moves]
    canon = canonical_moves(rs274(tmp_path, format_program(sh.program, "linuxcnc")))
    assert len(mine) == len(canon) > 400
    for mv, (kind, end, _, number) in zip(mine[2:], canon[2:]):  # the first two: home from anywhere
        assert mv.rapid == (kind == "STRAIGHT_TRAVERSE")
        assert isinstance(mv.move, Arc) == (kind == "ARC_FEED")
        assert np.allclose(mv.move.end, end, atol=1e-4)
        assert mv.label.split()[0] == f"N{number}"
    # the finishing contour: the toolpath's own moves, centres included
    arcs = [mv.move for mv in mine if isinstance(mv.move, Arc)]
    planned = [s for s in sh.program.toolpath.segments if isinstance(s, Arc)]
    assert len(arcs) == len(planned)
    assert np.allclose([a.centre for a in arcs], [a.centre for a in planned], atol=1e-4)


def test_siemens_program_simulates_as_the_model(shop):
    """The Siemens text replayed through the stock simulation gives the planned program's
    cycle time and removed volume (the same moves cut the same stock)."""
    settings, sh = shop
    ops = read_program(format_program(sh.program, "siemens"), settings.machine, DIALECTS["siemens"])
    t = settings.toolpath
    from lathe_mirror.shop.partoff import parting_z
    from lathe_mirror.shop.program import PARTING_STATION
    from lathe_mirror.shop.tool_shapes import blade_shape

    sim = simulate(ops, sh.program.toolpath.mirror, Hand.for_mirror(sh.program.toolpath.mirror).held(settings.tool),
                   settings.machine, settings.stock, rapid_rate=t.rapid_rate, gouge_tolerance=t.gouge_tolerance,
                   shapes={PARTING_STATION: blade_shape(t.parting_width_mm)},
                   parting=(parting_z(settings.body, settings.stock, t, settings.machine), t.parting_width_mm))
    assert sim.contacts == ()
    assert sim.cycle_time_s == pytest.approx(sh.simulation.cycle_time_s, rel=1e-9)
    removed = sum(op.removed_volume_mm3 for op in sim.operations)
    assert removed == pytest.approx(sum(op.removed_volume_mm3 for op in sh.simulation.operations), rel=1e-9)


def test_cli_writes_and_checks_a_siemens_program(tmp_path):
    res = run_cli("toolpath", "--dialect", "siemens", "-o", str(tmp_path) + "/")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mirror_arcs.mpf", "mirror_arcs.setup.html",
                                                         "mirror_arcs_op2.mpf", "tools.ini"]
    tools = (tmp_path / "tools.ini").read_text()
    assert '$TC_TP2[1]="T1"' in tools and "$TC_DP6[1,1]=0.2" in tools and "$TC_DP2[5,1]=9" in tools
    for name in ("mirror_arcs.mpf", "mirror_arcs_op2.mpf"):  # the dialect found from the file
        res = run_cli("toolpath", "--check", str(tmp_path / name))
        assert res.returncode == 0, res.stderr
        assert "no contact at rapid" in res.stdout
    # a word the Siemens dialect does not write is refused, naming the dialect
    bad = tmp_path / "bad.mpf"
    bad.write_text((tmp_path / "mirror_arcs.mpf").read_text().replace("G95 G64", "G95 G64 P0.001"))
    res = run_cli("toolpath", "--check", str(bad))
    assert res.returncode == 2 and "not simulated in the siemens dialect" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_fanuc_offsets_are_in_fanucs_form(shop):
    """Fanuc T series, programmable data input: G10 P_ X_ Z_ R_ Q_, P = 10000 + n for the
    geometry offset n (1..64 would be the wear offsets), R the nose radius, Q the imaginary
    tool nose (0: the nose centre); X and Z only where they are measured."""
    settings, sh = shop
    tools = sheet_tools([sh])
    # the inserts, the blade, and the bore's spot drill, drill and boring bar (shop.boring)
    assert [t.station for t in tools] == [1, 2, 5, 6, 7, 8]
    name, text = offset_table(tools, "fanuc")
    lines = text.splitlines()
    assert name == "offsets.nc" and lines[:2] == ["%", "O9001 (TOOL OFFSETS)"] and lines[-2:] == ["M30", "%"]
    g10 = [ln for ln in lines if ln.startswith("G10")]
    assert g10 == ["G10 P10001 R0.2 Q0", "G10 P10002 R0.2 Q0", "G10 P10005 R0.0 Q0", "G10 P10006 R0.0 Q0",
                   "G10 P10007 R0.0 Q0", "G10 P10008 R0.2 Q0"]
    _, measured = offset_table(tools, "fanuc", measured={2: Measured(x=-1.234, z=0.5)})
    assert "G10 P10002 X-1.2340 Z0.5000 R0.2 Q0" in measured.splitlines()
    # the LinuxCNC table: T, P, X, Z, the nose's diameter D, orientation Q (9: its centre)
    _, tbl = offset_table(tools, "linuxcnc", measured={1: Measured(x=3.0)})
    assert tbl.splitlines()[0].startswith("T1 P1 X3.0000 Z0 D0.400 Q9 ;")
    assert tbl.splitlines()[2].startswith("T5 P5 X0 Z0 D0.000 Q0 ;")


class Toy(Dialect):
    """A control of a test's own: words in lower-case keywords where the others differ."""

    name = "toy"
    label = "Toy control"
    extension = "toy"
    offsets_file = "toy_tools.txt"
    letters = frozenset("GMNTSFXZIK")

    def translate(self, line: str) -> str:
        if line.startswith(("begin ", "end")):
            return ""
        line = re.sub(r"^# (.*)$", r"(\1)", line)  # its comments
        line = re.sub(r"\btool (\d+)", r"T\1", line)
        return re.sub(r"\b(xdia|css|cap \d+)\b", lambda m: "G7" if m.group(0) == "xdia" else "", line)

    def comment(self, text: str) -> str:
        return "# " + text.replace("(", "[").replace(")", "]")

    def opening(self, program):
        return ["begin " + program.name]

    def closing(self):
        return ["end"]

    def preamble(self, program):
        return ["G18 G21 G90 xdia G95"]

    def tool_call(self, station, role):
        return [f"tool {station}"]

    def spindle_on(self, surface_speed, max_rpm, clockwise):
        return [f"cap {max_rpm}", f"G96 S{int(surface_speed)} M3"]

    def tip_code(self, tool):
        return "point C"

    def offset_entry(self, tool, diameter_mode):
        return f"tool {tool.station} radius {tool.offsets.nose_radius:g}"

    def offsets(self, tools, diameter_mode, measured=None):
        return "".join(self.offset_entry(t, diameter_mode) + "\n" for t in tools)


@pytest.fixture
def toy():
    d = register(Toy())
    yield d
    unregister(d.name)


def test_a_new_dialect_is_one_class(toy, shop, tmp_path):
    """Registered in this module, the toy control is written (its words), its offsets go
    to the sheet and beside the programs, the replay reads its program to the LinuxCNC
    program's moves, and the command line takes it; nothing else was touched."""
    settings, sh = shop
    text = format_program(sh.program, "toy")
    assert text.startswith("begin mirror_arcs\n# lathe-mirror mirror_arcs") and text.endswith("end\n")
    assert re.search(r"^N1 tool 1$", text, re.M) and "N2 cap 3000" in text
    files = program_files([sh])
    assert {"mirror_arcs.toy", "mirror_arcs_op2.toy", "toy_tools.txt"} <= set(files)
    assert files["toy_tools.txt"].splitlines() == ["tool 1 radius 0.2", "tool 2 radius 0.2", "tool 5 radius 0",
                                                   "tool 6 radius 0", "tool 7 radius 0", "tool 8 radius 0.2"]
    page = setup_sheet_html(sh.sheet)
    assert "Toy control (toy_tools.txt)" in page and "<code>tool 2 radius 0.2</code>" in page
    assert "Toy control point C" in page and "mirror_arcs.toy" in page
    toy_moves = [mv for op in read_program(text, settings.machine, toy) for mv in op.moves]
    lc_moves = [mv for op in read_program(format_program(sh.program, "linuxcnc"), settings.machine,
                                          DIALECTS["linuxcnc"]) for mv in op.moves]
    assert [(mv.rapid, mv.move) for mv in toy_moves] == [(mv.rapid, mv.move) for mv in lc_moves]
    res = run_cli("toolpath", "--dialect", "toy", "-o", str(tmp_path) + "/")
    assert res.returncode == 0, res.stderr
    assert {p.name for p in tmp_path.iterdir()} >= {"mirror_arcs.toy", "toy_tools.txt"}
    res = run_cli("toolpath", "--dialect", "heidenhain", "-o", str(tmp_path / "x.ngc"))
    assert res.returncode == 2 and "allowed linuxcnc, fanuc, siemens, toy" in res.stderr


def test_the_dialects_package_names_no_dialect_outside_its_modules():
    """Adding a control touches one module: no module outside export/dialects names a
    shipped dialect's class or module."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "lathe_mirror"
    for p in root.rglob("*.py"):
        if p.parent.name == "dialects":
            continue
        src = p.read_text()
        for name in ("dialects.linuxcnc", "dialects.fanuc", "dialects.siemens", "LinuxCNC(", "Fanuc(", "Siemens("):
            assert name not in src, (p, name)


def test_rs274_runs_the_program_with_the_table_written_beside_it(tmp_path, shop):
    """LinuxCNC's interpreter, an outside reader: with rs274's own default table the
    program stops at the part-off's tool ("Requested tool 5 not found"); with the tools.tbl
    the project writes it runs to the end, stopping (M0) before the part-off's tool change
    and optionally (M1) before the finishing tool's."""
    import os
    import subprocess

    from conftest import require_program

    _, sh = shop
    exe = require_program("rs274")
    files = program_files([sh], ("linuxcnc",))
    for name in ("mirror_arcs.ngc", "tools.tbl"):
        (tmp_path / name).write_text(files[name])
    env = dict(os.environ, HOME=str(tmp_path))
    bare = subprocess.run([exe, "-g", "mirror_arcs.ngc"], capture_output=True, text=True, cwd=tmp_path, env=env,
                          timeout=120)
    assert "Requested tool 5 not found" in bare.stdout + bare.stderr
    res = subprocess.run([exe, "-t", "tools.tbl", "-g", "mirror_arcs.ngc"], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=120)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    events = re.findall(r"(CHANGE_TOOL\(\d\)|OPTIONAL_PROGRAM_STOP|PROGRAM_STOP|PROGRAM_END)", res.stdout)
    # the table's rows: T1, T2, T5 (rs274 names a tool change by the row)
    assert events[-3:] == ["PROGRAM_STOP", "CHANGE_TOOL(3)", "PROGRAM_END"]
    i = events.index("OPTIONAL_PROGRAM_STOP")
    assert events[i + 1] == "CHANGE_TOOL(2)" and set(events[:i]) == {"CHANGE_TOOL(1)"}
    assert "PROGRAM_STOP" not in events[:-3]
    # the roughing feed: half the 0.2 mm nose per revolution (machine.feed_rough 0.15 is more)
    assert "SET_FEED_RATE(0.1000)" in res.stdout
