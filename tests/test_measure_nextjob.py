"""What `compensate` hands on (measure.nextjob): the next job whole, taken with `--from`.

The design's own profile (closed form, tests/shop_model.design_z) with an 8 um PV form error
is compensated in the Fanuc dialect: the programs (.nc, first and second set-up), the
sheet, Fanuc's offset list (no LinuxCNC tools.tbl beside a .nc), job.toml (a configuration
`config.load` takes, with the nose radius and strategy the program was planned for) and
compensate.json (the re-cut's target, the entries to make). `--from DIR` with `--config`,
or a compensate.json that is not one, is refused with one line, exit 2; `--program` takes
every strategy name (best and lattice here, a name that is none refused)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import run_cli
from shop_model import design_z


@pytest.fixture(scope="module")
def trace(tmp_path_factory):
    from lathe_mirror.config import load

    m = load(None).mirror()
    d = tmp_path_factory.mktemp("nextjob")
    x = np.arange(-m.r_max + 0.01, m.r_max - 0.01, 0.004)
    r = np.abs(x)
    z = design_z(m, r) + 4e-3 * np.cos(2 * np.pi * r / 7.0) + np.random.default_rng(4).normal(0, 2e-5, x.size)
    p = d / "part.csv"
    p.write_text("x [mm],z [mm]\n" + "".join(f"{a:.6f},{b:.7f}\n" for a, b in zip(x, z)))
    return p


def test_compensate_writes_the_next_job_whole(trace, tmp_path):
    out_dir = tmp_path / "job1"
    res = run_cli("compensate", str(trace), "--dialect", "fanuc", "--program", "best", "-o", str(out_dir))
    assert res.returncode == 0, res.stderr
    names = sorted(p.name for p in out_dir.iterdir())
    assert names == sorted(["mirror_recut.nc", "mirror_recut_op2.nc", "mirror_recut.setup.html", "offsets.nc",
                            "job.toml", "compensate.json"])
    offsets = (out_dir / "offsets.nc").read_text()
    # Fanuc's own form: G10 P10000+n sets geometry offset n, R the nose radius, Q0 the nose centre
    assert "G10 P10002 R0.200 Q0" in offsets.replace("R0.2 ", "R0.200 ")
    from lathe_mirror.config import load

    settings = load(out_dir / "job.toml")  # a configuration every command takes
    assert settings.tool.nose_radius == 0.2 and settings.toolpath.strategy.value == "arcs"
    data = json.loads((out_dir / "compensate.json").read_text())
    nxt = data["next_job"]
    assert nxt["strategy"] == "arcs" and nxt["touch_off"]["x_side"] == "bore"
    assert set(nxt["set_up_entries"]) == {"raise_tool_mm", "x_zero_toward_axis_mm", "nose_radius_mm"}
    assert "part-off" in nxt["repeats"] and "finish" in nxt["repeats"]
    # the 8 um PV cosine is compensated: the target lowers each lobe by the gain x what the
    # machine added to the program's own part (the cosine less the arcs program's form on a
    # perfect machine, 0.47 um PV inner: tests/shop_model.py on gcode/mirror_arcs.ngc)
    assert data["compensation"]["residual_compensated"] and nxt["target"] is not None
    from lathe_mirror.measure.nextjob import target_from_dict

    target = target_from_dict(nxt["target"], settings.mirror(), "compensate.json")
    m = settings.mirror()
    rr = np.linspace(2.0, 16.0, 50)
    lowered = (np.asarray(m.inner.z(rr)) - np.asarray(target.inner.z(rr))) * 1e3  # um, camera z
    expect = 0.8 * 4.0 * np.cos(2 * np.pi * rr / 7.0)  # the part stands high by the cosine (machine Z)
    assert np.abs((lowered - lowered.mean()) + (expect - expect.mean())).max() < 0.5, lowered
    # the next measure takes the directory as it is
    res = run_cli("measure", str(trace), "--from", str(out_dir), "--json")
    assert res.returncode == 0, res.stderr
    job = json.loads(res.stdout)["job"]
    assert job["strategy"] == "arcs" and job["target"].startswith("re-cut")
    res = run_cli("measure", str(trace), "--program", "lattice", "--json")  # every strategy name
    assert res.returncode == 0 and json.loads(res.stdout)["job"]["strategy"] == "lattice", res.stderr


def test_from_refusals(trace, tmp_path):
    d = tmp_path / "job"
    d.mkdir()
    (d / "job.toml").write_text("[tool]\nnose_radius = 0.2\n")
    res = run_cli("measure", str(trace), "--from", str(d), "--config", str(d / "job.toml"))
    assert res.returncode == 2 and "name one of them" in res.stderr
    (d / "compensate.json").write_text('{"next_job": {"target": {"lobes": [{"name": "inner"}]}}}')
    res = run_cli("measure", str(trace), "--from", str(d))
    assert res.returncode == 2 and "not a re-cut target of this design" in res.stderr, res.stderr
    res = run_cli("measure", str(trace), "--program", "sideways")
    assert res.returncode == 2 and "allowed" in res.stderr and "lattice" in res.stderr, res.stderr
