"""Valid for every command or for none (issue 35): each numeric key's documented
endpoints, the other keys at their defaults, through `design` (settings.validate's
check_commands, what `lathe-mirror design` runs) and through the command that uses the
key, with the checks that command makes before its work (the calls of its module). A
configuration `design` accepts is accepted by its key's own command; an end `design`
refuses is declared (`lo_depends` / `hi_depends`) and its message names the key or what
the declaration says bounds it (a design's input, camera.* or lobes.*: what the design
breaks). The named cases of the fuzz round run through the CLI.

Fast: the programs are planned and their gouge depths found once per distinct (design,
lathe, tool, strategy, deviation) (job.plan and job.gouge_depth memoised for this module).
"""

from __future__ import annotations

import dataclasses
import re

import pytest

import lathe_mirror.job as job
from lathe_mirror.errors import InputError
from lathe_mirror.job import check_cad, check_program, check_programs
from lathe_mirror.settings import from_config
from lathe_mirror.settings.validate import check_commands, check_render_nose
from lathe_mirror.shop.plan import check_stock

from conftest import run_cli
from test_keys import NUMERIC, _ends, _inside, _value, _with


def _toolpath(s, m):
    check_stock(m, s.stock, s.toolpath, s.machine)
    check_program(s, m, s.toolpath.strategy)


def _cad(s, m):
    check_cad(s, m)
    check_program(s, m, s.toolpath.strategy)  # the DXF's toolpath layers


def _render(s, m):
    check_render_nose(s, m)
    nose = s.render.nose_radius
    check_program(s, m, s.render.surface, tool=dataclasses.replace(s.tool, nose_radius=nose) if nose > 0 else None)


def _stereo(s, m):
    check_program(s, m, s.stereo.surface)


def _polish(s, m):
    check_programs(s, m, tolerance=False)


def _tolerance(s, m):
    check_programs(s, m)
    for program in s.tolerance.programs:
        check_program(s, m, program)


#: The command that uses each section's keys, as the checks its module makes up front.
COMMAND = {"machine": _toolpath, "tool": _toolpath, "stock": _toolpath, "toolpath": _toolpath, "cad": _cad,
           "render": _render, "scene": _render, "camera_pose": _render, "stereo": _stereo, "polish": _polish,
           "tolerance": _tolerance, "compute": _tolerance, "machine.errors": _render}


def _command(name: str):
    for prefix in sorted(COMMAND, key=len, reverse=True):
        if name.startswith(prefix + "."):
            return COMMAND[prefix]
    return None  # camera, lobes, optimize: `design` / `optimize` load and check the design alone


@pytest.fixture(scope="module", autouse=True)
def _plans_once():
    """job.plan memoised on its inputs (a program is a pure function of them), and the
    gouge depth of each program so planned."""
    plan, cache = job.plan, {}

    def memo(mirror, lathe, tool, strategy=job.BEST, *, max_deviation=0.01, phase=0.0, target=None):
        if target is not None:
            return plan(mirror, lathe, tool, strategy, max_deviation=max_deviation, phase=phase, target=target)
        lobes = tuple((lb.a, lb.b, lb.e, lb.r_top, lb.h) for lb in (mirror.inner, mirror.outer))
        k = (lobes, lathe, tool, strategy, max_deviation, phase)
        if k not in cache:
            try:
                cache[k] = plan(mirror, lathe, tool, strategy, max_deviation=max_deviation, phase=phase)
            except InputError as exc:
                cache[k] = exc
        if isinstance(cache[k], InputError):
            raise cache[k]
        return cache[k]

    depth, depths = job.gouge_depth, {}

    def gouge(tp):
        if id(tp) not in depths:
            depths[id(tp)] = (tp, depth(tp))  # the toolpath kept: its id stays its own
        return depths[id(tp)][1]

    job.plan, job.gouge_depth = memo, gouge
    yield
    job.plan, job.gouge_depth = plan, depth


def _refusal(fn, *args) -> str | None:
    try:
        fn(*args)
    except InputError as exc:
        return str(exc)
    return None


CASES = [(k, side, end, depends) for k in NUMERIC for side, end, depends in _ends(k)]


@pytest.mark.parametrize("k, side, end, depends", CASES,
                         ids=[f"{c[0].name}{'-lo' if c[1] < 0 else '-hi'}" for c in CASES])
def test_a_documented_end_design_accepts_its_command_accepts(k, side, end, depends):
    value = _value(k, _inside(k, end, side), side)
    try:
        settings = from_config(_with(k, value))
    except InputError:
        return  # refused by load(): every command refuses it (test_keys holds the message)
    mirror = settings.mirror()
    refused = _refusal(check_commands, settings, mirror)
    command = _command(k.name)
    if refused is None:
        if command is not None:
            assert _refusal(command, settings, mirror) is None, f"{k.name} = {value}: design accepts it"
        return
    assert depends, f"{k.name} = {value}: the documented end is refused by design: {refused}"
    if k.name.startswith(("camera.", "lobes.")):
        return  # a design's input: the message names what the design breaks (the bar, the body, the room)
    named = [k.name.split("[")[0]] + re.findall(r"\b[a-z_]+\.[a-z_.\[\]*]*[a-z_]\b", k.depends)
    assert any(n.replace(".*", "") in refused for n in named), (k.name, k.depends, refused)


@pytest.mark.parametrize("toml, command, key", [
    ("[cad]\nmin_wall = 10000.0\n", ["cad", "-o", "m.dxf"], "cad.min_wall"),
    ("[tolerance.params]\nresolution_mm = 0.1\n", ["tolerance", "-o", "tol"], "tolerance.params.resolution_mm"),
    ("[toolpath]\nhome_r = 1000.0\n", ["toolpath", "-o", "p.ngc"], "toolpath.home_r"),
    ("[render]\nnose_radius = 5.0\n", ["render", "-o", "img"], "render.nose_radius"),
])
def test_the_fuzz_rounds_cases_are_refused_by_design_and_their_command(toml, command, key, tmp_path):
    """The four cases issue 35 names: `design` refused nothing, the command exit 2; now
    both refuse with one line naming the key."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(toml)
    for argv in (["design"], command):
        proc = run_cli(*argv, "--config", str(cfg), cwd=tmp_path)
        assert proc.returncode == 2, (argv, proc.stderr)
        assert key in proc.stderr and "Traceback" not in proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]  # nothing written


def test_every_documented_uniqueness_ratio_runs_the_matcher():
    """stereo.uniqueness_ratio's documented ends (0 and 99 %) run OpenCV's 3-way matcher on
    a textured pair shifted by 5 px and find that shift (100 divides by zero in it: SIGFPE,
    exit 136, so it is refused by load with one line)."""
    import numpy as np

    from lathe_mirror.declared import key
    from lathe_mirror.optics.ranging.match import MatchParams, match

    rng = np.random.default_rng(7)
    right = rng.uniform(0.0, 255.0, (48, 160))
    left = np.roll(right, 5, axis=1)  # left x sees right x - 5
    k = key("stereo.uniqueness_ratio")
    for ratio in (k.lo, k.hi):
        d = match(left, right, MatchParams(uniqueness_ratio=ratio))
        inner = d[8:-8, 40:-8]
        assert np.nanmedian(inner) == pytest.approx(5.0, abs=0.25), ratio
    with pytest.raises(InputError) as exc:
        from_config(_with(k, 100))
    assert "stereo.uniqueness_ratio = 100" in str(exc.value) and "0 to 99" in str(exc.value)
