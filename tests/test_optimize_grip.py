"""optimize's grip constraint (issue 32's loose end): the configured toolpath.min_grip_mm
and half the parted part's stand-out, the rule the second set-up refuses by, against hand
values on the paper design and against the shop's own refusal; a grip no body can leave
refused before the search."""

from __future__ import annotations

import dataclasses

import pytest

from conftest import run_cli
from lathe_mirror.config import load


#: The paper design's outer rim below its vertex, from the shop's own second set-up
#: (test_boring: at cad.thickness 30 its soft jaws grip 7.2215 mm, from the shoulder at
#: Z-10.2215 to the jaws' end 3 mm below the back): 30 - 3 - 7.2215 mm.
PAPER_RIM_DEPTH = 30.0 - 3.0 - 7.2215


@pytest.mark.parametrize("text, thickness, grip", [
    # the configured least grip binds: 3 mm jaw gap + 7.25 mm
    ("[toolpath]\nmin_grip_mm = 7.25\n", 30.0, 3.0 + 7.25),
    ("[toolpath]\nmin_grip_mm = 7.2\n", 30.0, 3.0 + 7.2),
    ("[toolpath]\nmin_grip_mm = 12.0\n[cad]\nthickness = 36.0\n", 36.0, 3.0 + 12.0),
    # half the stand-out binds: a 20 mm boss and the 0.5 mm back allowance stand the parted
    # part 20.5 + 3 mm out of the jaws, half of it 11.75 mm > 5 mm
    ("[cad]\nmount = \"boss\"\nmount_depth = 20.0\n[stock]\nlength = 60.0\n", 30.0, 3.0 + 0.5 * (20.5 + 3.0)),
])
def test_optimize_counts_the_configured_grip(tmp_path, text, thickness, grip):
    """optimize's grip constraint takes the configured toolpath.min_grip_mm and half the
    part's stand-out (the rule shop.second refuses by), not the default 5 mm: on the paper
    design the violation is the hand value rim depth + jaw gap + grip - thickness (0 when
    it holds: 7.2 mm fits the shop's 7.2215, 7.25 mm breaks it by 0.0285 mm)."""
    from lathe_mirror.optimize.evaluate import CONSTRAINTS, figures, violations
    from lathe_mirror.optimize.winner import problem_of

    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    s = load(cfg)
    problem = problem_of(s)
    assert problem.grip_mm == pytest.approx(grip, abs=1e-9)
    j = next(i for i, c in enumerate(CONSTRAINTS) if "second set-up" in c.what)
    v = violations(figures(s.lobes, problem), problem)[j]
    assert v == pytest.approx(max(0.0, PAPER_RIM_DEPTH + grip - thickness), abs=1e-3)


def test_optimize_grip_agrees_with_the_shops_refusal(tmp_path):
    """The boss body above, as the shop plans it (its parted part simulated, reversed and
    gripped): plan_second refuses it with the grip it has and the grip it needs, and
    optimize's violation of the paper design is their difference."""
    import re

    from lathe_mirror.enums import Strategy
    from lathe_mirror.errors import InputError
    from lathe_mirror.optimize.evaluate import CONSTRAINTS, figures, violations
    from lathe_mirror.optimize.winner import problem_of
    from lathe_mirror.shop.programs import shop_programs

    cfg = tmp_path / "c.toml"
    cfg.write_text("[cad]\nmount = \"boss\"\nmount_depth = 20.0\n[stock]\nlength = 60.0\n")
    s = load(cfg)
    with pytest.raises(InputError) as exc:
        shop_programs(s, s.mirror(), strategies=(Strategy.ARCS,))
    have, need = map(float, re.search(r"back, ([\d.]+) mm; allowed a thickness that leaves at least ([\d.]+) mm",
                                        str(exc.value)).groups())
    problem = problem_of(s)
    j = next(i for i, c in enumerate(CONSTRAINTS) if "second set-up" in c.what)
    assert violations(figures(s.lobes, problem), problem)[j] == pytest.approx(need - have, abs=0.006)
    assert need == pytest.approx(11.75, abs=1e-9)


def test_optimize_refuses_a_grip_no_body_holds_before_it_searches(tmp_path, monkeypatch):
    """toolpath.min_grip_mm = 30 mm in a 30 mm body: the jaws need 30 + 3 mm below the
    rim's shoulder, which is never above the vertex, so no design fits; one line, exit 2,
    nothing written, and neither the made parts' Monte Carlo nor the search ran."""
    import lathe_mirror.optimize.winner as winner

    def ran(*args, **kwargs):
        raise AssertionError("searched")

    monkeypatch.setattr(winner, "search", ran)
    monkeypatch.setattr(winner, "made_parts", ran)
    cfg = tmp_path / "c.toml"
    cfg.write_text("[toolpath]\nmin_grip_mm = 30.0\n")
    out = tmp_path / "best.toml"
    proc = run_cli("optimize", "--config", str(cfg), "-o", str(out), "--no-progress")
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert lines[0].startswith("lathe-mirror optimize: error: toolpath.min_grip_mm = 30 mm:")
    assert "33.000 mm" in lines[0] and "allowed < 27 mm" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]


def test_a_boss_too_long_for_any_grip_names_the_mount_depth():
    """A 52 mm boss on a 30 mm body stands the parted part 52.5 + 3 mm out of the jaws:
    half of it, 27.75 mm, plus the 3 mm gap exceeds the body (hand: 30.75 > 30)."""
    from lathe_mirror.enums import Mount
    from lathe_mirror.errors import InputError
    from lathe_mirror.optimize.evaluate import check_grip_room, second_grip_mm

    s = load()
    body = dataclasses.replace(s.body, mount=Mount.BOSS, mount_depth=52.0)
    assert second_grip_mm(body, s.toolpath, s.machine) == pytest.approx(3.0 + 0.5 * (52.5 + 3.0), abs=1e-9)
    with pytest.raises(InputError, match=r"^cad.mount_depth = 52 mm: .* 30\.750 mm"):
        check_grip_room(body, s.toolpath, s.machine)
    check_grip_room(dataclasses.replace(body, mount_depth=50.0), s.toolpath, s.machine)  # 3 + 26.75 < 30
