"""The body follows the bar (issue 31): cad.blank_diameter is the [stock] diameter and
cad.thickness fits the bar's length unless the configuration sets them; a body the bar
cannot give is refused in one line before `optimize` searches. Bars of 40, 60 and 100 mm.
"""

from __future__ import annotations

import time

import pytest

from lathe_mirror.config import load
from lathe_mirror.errors import InputError
from lathe_mirror.job import cad_model

from conftest import run_cli

#: A 6 mm lens with 3 um pixels: a mirror 25.9 mm across, small enough for a 40 mm bar.
SMALL = ("[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n"
         "[lobes.inner]\nr_top = 5.143250067202264\nr_pixel = 354.34622080440613\nalpha_deg = 0.16491580636968806\n"
         "[lobes.outer]\nr_top = 12.962773350532286\nr_pixel = 511.82075923486775\nalpha_deg = 0.14021089596690714\n")


def _load(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return load(path)


@pytest.mark.parametrize("bar, design", [(40.0, SMALL), (60.0, SMALL), (100.0, "")])
def test_the_body_is_the_bars_diameter(bar, design, tmp_path):
    """The drawn body's outside radius (the design meridian's largest r) is half the bar's
    diameter, not the 76 mm default."""
    settings = _load(tmp_path, design + f"[stock]\ndiameter = {bar}\n")
    assert settings.body.blank_diameter == bar
    mer = cad_model(settings, settings.mirror(), programmed=False).design
    r_out = max(max(s.start[0], s.end[0]) for s in mer.segments)
    assert r_out == pytest.approx(bar / 2, abs=1e-9)


def test_a_body_the_configuration_sets_is_kept(tmp_path):
    settings = _load(tmp_path, "[stock]\ndiameter = 100.0\n[cad]\nblank_diameter = 80.0\nthickness = 28.0\n")
    assert (settings.body.blank_diameter, settings.body.thickness) == (80.0, 28.0)


def test_the_thickness_fits_a_short_bar(tmp_path):
    """A 30 mm bar: the body is what is left above the part-off, 30 - 3 (blade) - 0.5 (back
    allowance) = 26.5 mm; a 40 mm bar keeps the declared 30 mm (36.5 mm would fit); a 22 mm
    bar leaves 18.5 mm, less than the paper mirror's 19.78 mm depth plus the 2 mm wall, so
    the declared 30 mm stays and the refusal names the bar."""
    assert _load(tmp_path, "[stock]\nlength = 30.0\n").body.thickness == 26.5
    assert _load(tmp_path, "[stock]\nlength = 40.0\n").body.thickness == 30.0
    with pytest.raises(InputError, match=r"^stock\.length = 22 mm: .* needs the bar 33\.5 mm"):
        _load(tmp_path, "[stock]\nlength = 22.0\n")


@pytest.mark.parametrize("text, keys", [
    ("[stock]\ndiameter = 40.0\n[cad]\nblank_diameter = 76.0\n", ("cad.blank_diameter", "stock.diameter")),
    ("[stock]\nlength = 20.0\n[cad]\nthickness = 30.0\n", ("stock.length", "cad.thickness")),
])
def test_optimize_refuses_an_impossible_body_before_it_searches(text, keys, tmp_path):
    """A body larger than the bar, or too long to part off it: one line, exit 2, no search
    (the paper default's search takes minutes; this answers in seconds)."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(SMALL + text)
    t0 = time.perf_counter()
    proc = run_cli("optimize", "--config", str(cfg), "-o", str(tmp_path / "best.toml"), cwd=tmp_path)
    assert time.perf_counter() - t0 < 30
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and all(k in proc.stderr for k in keys), proc.stderr
    assert not (tmp_path / "best.toml").exists()
