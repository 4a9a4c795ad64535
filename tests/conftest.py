"""Shared test helpers.

External programs (rs274, freecadcmd, povray) are run for real. On a developer's machine
a missing program skips its tests with the reason; under CI=true it fails them.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from lathe_mirror.settings import from_config
from lathe_mirror.config import default_config

IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")

#: A design whose OUTER lobe is recessed at the step (README "Your own design", with
#: r_pixel = 265): the program cuts it with the insert in an opposite-hand holder, from the
#: rim in (toolpath.Hand.OPPOSITE).
RECESSED_OUTER = ("[camera]\nf = 6.0\nt_pixel = 0.003\nsensor_px = [1280, 1024]\n"
                  "[lobes.inner]\nr_top = 12.0\nr_pixel = 265.0\na_over_b = 2.0\n"
                  "[lobes.outer]\nr_top = 25.0\nr_pixel = 500.0\nalpha_deg = 5.0\n")


#: A configuration no program can cut (the paper's 1.82 mm step with a 1 mm nose, which
#: cannot reach the step wall): every stage that needs a program refuses it with one line
#: (UNCUTTABLE_PHRASE) before it writes anything.
UNCUTTABLE = "[tool]\nnose_radius = 1.0\n"
UNCUTTABLE_PHRASE = "too large for the junction"


def require_program(name: str) -> str:
    """Path of an external program; skip (laptop) or fail (CI=true) when it is missing."""
    path = shutil.which(name)
    if path is None:
        msg = f"external program '{name}' is not installed (scripts/bootstrap installs it)"
        if IN_CI:
            pytest.fail(msg + "; CI=true requires it", pytrace=False)
        pytest.skip(msg)
    return path


#: LATHE_MIRROR_TEST_FRESH=1 runs every run_cli in a fresh process (as fresh=True does).
FRESH = os.environ.get("LATHE_MIRROR_TEST_FRESH", "") not in ("", "0")


def run_cli(*args: str, cwd=None, env=None, fresh: bool = False) -> subprocess.CompletedProcess:
    """Run `lathe-mirror ARGS`; returns the completed process (exit status, stdout, stderr).

    By default in this process: the command line's own entry point (cli.main, its signal
    handlers, its staged files and exit status) with stdout and stderr captured, in `cwd`
    with `env` as the environment for the call; what a new interpreter would add is its
    start-up and imports, ~0.3-1 s a command, which the suite's ~200 calls would pay each.
    fresh=True (or LATHE_MIRROR_TEST_FRESH=1): in a new process, for what only a process
    shows (the modules a command imports, the interpreter's own exit)."""
    if fresh or FRESH:
        return subprocess.run([sys.executable, "-m", "lathe_mirror", *args],
                              capture_output=True, text=True, cwd=cwd, env=env, timeout=600)
    return _run_in_process(list(args), cwd, env)


def _run_in_process(args: list[str], cwd, env) -> subprocess.CompletedProcess:
    import contextlib
    import io

    from lathe_mirror.cli import main

    out, err = (io.TextIOWrapper(io.BytesIO(), encoding="utf-8", newline="") for _ in range(2))
    old_cwd, old_env = os.getcwd(), dict(os.environ)
    try:
        if cwd is not None:
            os.chdir(cwd)
        if env is not None:
            os.environ.clear()
            os.environ.update(env)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(args)
            except SystemExit as exc:  # argparse: --help, --version, a usage error
                status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        os.chdir(old_cwd)
        if env is not None:
            os.environ.clear()
            os.environ.update(old_env)
    texts = []
    for stream in (out, err):
        stream.flush()
        texts.append(stream.buffer.getvalue().decode("utf-8"))
    return subprocess.CompletedProcess(["lathe-mirror", *args], status, texts[0], texts[1])


#: The modules that take longest, longest first (their CPU seconds, user+sys with children,
#: each module alone with `-n 0` on the 2-core machine under load: test_docs ~79,
#: test_optimize ~74, test_sampling ~54, test_report ~54, test_designs ~51, test_fuzz ~42,
#: test_run ~40, test_shop, test_measure_loop, test_sampled_range ~38-40, test_calib ~32,
#: test_signals ~30, ... test_boring ~6; the rest under 5 s each), handed to the workers
#: first: `--dist loadscope --no-loadscope-reorder` (scripts/test) gives each worker the next
#: module in collection order as it frees, so with the longest first the two workers finish
#: together instead of one waiting for the docs' site build (xdist's own order is by the
#: number of tests, which put that module last) or starting a 40 s module when the other has
#: only small modules left.
LONGEST_FIRST = ("test_docs", "test_optimize", "test_sampling", "test_report", "test_designs", "test_fuzz", "test_run",
                 "test_shop", "test_measure_loop", "test_sampled_range", "test_calib", "test_signals",
                 "test_reliability", "test_gcode", "test_compute", "test_outer_step", "test_tolerance", "test_measure",
                 "test_bounds", "test_job", "test_machine_errors", "test_step", "test_measure_judge", "test_boring",
                 "test_drawing_callouts", "test_dialects", "test_povray", "test_partoff", "test_results",
                 "test_trace3d", "test_plausible", "test_polish", "test_ranging", "test_measured_bounds",
                 "test_gcode_optics", "test_finish_exit", "test_measure_tolerance", "test_measure_backlash",
                 "test_cad_cli", "test_endpoints_commands", "test_api_misuse", "test_api_script", "test_config_cli",
                 "test_layers", "test_machining", "test_render", "test_optics_distortion", "test_lazy_imports",
                 "test_spec")


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.stem, len(rank)))  # stable: a module's own order kept


@pytest.fixture(scope="session", autouse=True)
def _commands_run_serially_here():
    """A command called in this process without --workers runs its trials here, not in a
    pool of all the cores ([compute] workers = 0): the suite's own workers (pytest-xdist)
    already hold the cores, and a nested pool of 2 doubled the CPU of the same work
    (tolerance, docs_fast.toml: 14.4 s against 7.2 s on the 2-core reference machine) for
    the same bytes (compute's executors give one answer, tests/test_compute.py). A test of
    the pool asks for it (--workers 2, compute.session(workers=2)); a fresh process
    (run_cli(fresh=True), subprocess) keeps the default."""
    from lathe_mirror import compute

    patch = pytest.MonkeyPatch()
    patch.setattr(compute, "default_workers", lambda: 1)
    yield
    patch.undo()


@pytest.fixture(scope="session")
def paper_config() -> dict:
    return default_config()


@pytest.fixture(scope="session")
def paper_mirror(paper_config):
    return from_config(paper_config).mirror()


@pytest.fixture(scope="module", params=["paper", "recessed"])
def design_case(request, tmp_path_factory) -> dict:
    """The paper default and a design that is not the paper's (RECESSED_OUTER: a 6 mm lens,
    the outer lobe recessed), each with its config file (None: the default), settings,
    mirror and a directory of its own; a module's tests run on both."""
    d = tmp_path_factory.mktemp(request.param)
    cfg = None
    if request.param == "recessed":
        cfg = d / "recessed.toml"
        cfg.write_text(RECESSED_OUTER)
    from lathe_mirror.config import load

    settings = load(cfg)
    return {"name": request.param, "cfg": cfg, "settings": settings, "mirror": settings.mirror(), "dir": d}

