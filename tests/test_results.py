"""The typed results (issue 26): each stage's result is a frozen dataclass whose
`to_dict()` is exactly the section of report.json the report writes, read back by
`from_dict()`; their figures against independent sources (Table 1, closed forms)."""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

import lathe_mirror as lm
from lathe_mirror.design_table import design_figures
from lathe_mirror.pipeline import report_figures
from lathe_mirror.report import write_report
from lathe_mirror.report.analysis import ReportData
from lathe_mirror.results.base import Result

from conftest import RECESSED_OUTER

#: The paper's Table 1 (mm): c (its focal distance 2e), h, a, b of mirrors 01 (inner) and 02 (outer).
TABLE1 = {"inner": (110.6399, 115.6071, 48.3584, 26.8656), "outer": (123.4397, 123.4568, 46.6611, 40.3990)}


@pytest.fixture(scope="module")
def recessed(tmp_path_factory):
    """The report of a design that is not the paper's (outer lobe recessed; a 6 mm lens,
    3 um pixels), without the renders and the tolerance analysis (the heavy stages)."""
    path = tmp_path_factory.mktemp("cfg") / "recessed.toml"
    path.write_text(RECESSED_OUTER + "[polish]\ncurve_points = 5\n")
    settings = lm.load(path)
    data = report_figures(settings, renders=False, tolerance=False)
    out = tmp_path_factory.mktemp("report")
    paths = write_report(data, out)
    return settings, data, json.loads(paths["json"].read_text())


def _results(data: ReportData):
    """(section, result) of every typed result the report holds."""
    for name in ReportData.SECTIONS:
        v = getattr(data, name)
        if isinstance(v, Result):
            yield name, v
        elif isinstance(v, dict) and v and all(isinstance(x, Result) for x in v.values()):
            yield from ((f"{name}.{k}", x) for k, x in v.items())
        elif isinstance(v, tuple) and v and all(isinstance(x, Result) for x in v):
            yield from ((f"{name}[{i}]", x) for i, x in enumerate(v))


def ordered(v):
    """v with every dict as its list of (key, value) pairs: equal only in the same key order."""
    if isinstance(v, dict):
        return [(k, ordered(x)) for k, x in v.items()]
    if isinstance(v, list):
        return [ordered(x) for x in v]
    return v


def _section(written: dict, where: str):
    node = written
    for part in where.replace("[", ".").replace("]", "").split("."):
        node = node[int(part)] if part.isdigit() else node[part]
    return node


def test_each_result_is_the_json_the_report_writes(recessed):
    """to_dict() of each result is its section of report.json (through the same JSON
    writer: the floats at their stated precision), and from_dict() reads it back."""
    from lathe_mirror.export.files import json_text

    _, data, written = recessed
    seen = set()
    for where, result in _results(data):
        as_written = json.loads(json_text({"x": result.to_dict()}))["x"]
        assert ordered(as_written) == ordered(_section(written, where)), where  # keys in the same order too
        again = type(result).from_dict(result.to_dict())
        assert again.to_dict() == result.to_dict(), where
        seen.add(where.split(".")[0].split("[")[0])
    assert {"design", "machine", "toolpaths", "zones", "mirrors", "made_mirror", "calibration", "stereo"} <= seen
    assert list(written) == ["schema", *(s for s in ReportData.SECTIONS if getattr(data, s) is not None)]


def test_results_are_frozen(recessed):
    _, data, _ = recessed
    for where, result in _results(data):
        f = dataclasses.fields(result)[0]
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(result, f.name, None)
        assert not hasattr(result, "__dict__"), where  # slots: no attribute can be added either
    lobe = data.mirrors["best"].lobes[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        lobe.image_displacement_px.rms = 0.0


def test_strict_from_dict():
    """A figure the type does not declare is an error (a stage that grows a figure grows its type)."""
    d = design_figures(lm.load().mirror())
    d["lobes"][0]["unexpected_mm"] = 1.0
    from lathe_mirror.results import DesignFigures

    with pytest.raises(lm.InputError, match="unexpected_mm"):
        DesignFigures.from_dict(d)


def test_design_figures_are_table_1():
    """The paper default's typed design figures against the paper's Table 1."""
    from lathe_mirror.results import DesignFigures

    d = DesignFigures.from_dict(design_figures(lm.load().mirror()))
    for name, (c, h, a, b) in TABLE1.items():
        lobe = d.lobe(name)
        assert (lobe.c, lobe.h, lobe.a, lobe.b) == pytest.approx((c, h, a, b), abs=6e-5)
    t = d.table()
    assert list(t["name"]) == ["inner", "outer"]
    assert t["a"] == pytest.approx([TABLE1["inner"][2], TABLE1["outer"][2]], abs=6e-5)


def test_recessed_design_and_mirror_figures_against_closed_forms(recessed):
    """Another design: each lobe's e = sqrt(a^2 + b^2), c = 2e, R = b^2 / a, k = -1 - (b/a)^2;
    the exact mirror has no image displacement and no depth error; the tables hold the
    attributes' numbers."""
    settings, data, _ = recessed
    for lobe, spec_a_over_b in zip(data.design.lobes, (2.0, None)):
        assert lobe.e == pytest.approx(math.hypot(lobe.a, lobe.b), rel=1e-12)
        assert lobe.c == pytest.approx(2 * lobe.e, rel=1e-12)
        assert lobe.R_mm == pytest.approx(lobe.b**2 / lobe.a, rel=1e-12)
        assert lobe.k == pytest.approx(-1 - (lobe.b / lobe.a) ** 2, rel=1e-12)
        if spec_a_over_b:
            assert lobe.a / lobe.b == pytest.approx(spec_a_over_b, rel=1e-9)
    assert data.design.camera.f == 6.0 and data.design.junction.recessed == "outer"
    exact = data.mirrors["exact"]
    assert all(lb.image_displacement_px.rms < 1e-6 for lb in exact.lobes)
    assert data.stereo.at["exact"].rms < 1e-6 and data.stereo.at["exact"].failed == 0
    t = data.mirrors["best"].table()
    assert list(t["image_displacement_px_rms"]) == [lb.image_displacement_px.rms for lb in data.mirrors["best"].lobes]
    curve = data.stereo.curves["best"].table()
    assert list(curve["range_m"]) == list(data.stereo.curves["best"].ranges_m)
    rows = {r.strategy: r for r in data.toolpaths}
    assert rows["arcs"].best and rows["arcs"].moves.g2_g3 > 0 and rows["paper"].moves.g2_g3 == 0
    assert data.made_mirror.nose_radius_mm == settings.tool.nose_radius


def test_report_figures_are_the_sections_in_order():
    """ReportData.figures: the schema, then every computed section in report.json's order."""
    from lathe_mirror.results import DesignFigures

    data = ReportData(design=DesignFigures.from_dict(design_figures(lm.load().mirror())), notes=("a note",))
    assert list(data.figures) == ["schema", "notes", "design"]
    assert data.figures["notes"] == ["a note"] and data.verdict is None
