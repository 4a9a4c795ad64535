"""One executor (lathe_mirror.compute) for the Monte Carlo and the optimiser: the same seed
gives the same figures and yield serially, on local worker processes and on a Dask
cluster; a signal to the process group ends a pool within a second, with no orphan and no
file; bad --workers / --scheduler are refused with one line."""

from __future__ import annotations

import copy
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import run_cli
from lathe_mirror import compute
from lathe_mirror.enums import Program
from lathe_mirror.tolerance.runs import tolerance_context
from lathe_mirror.settings import from_config
from lathe_mirror.tolerance.montecarlo import draw_trials, evaluate_trials, judge

QUICK = ('[polish]\ncurve_points = 3\n[tolerance]\ntrials = {trials}\nlattice_phases = 1\nnose_step_mm = 0.005\n'
         'programs = ["best"]\n')


@pytest.fixture(scope="module")
def ctx(paper_config, paper_mirror):
    cfg = copy.deepcopy(paper_config)
    cfg["tolerance"].update(lattice_phases=1, trials=60, nose_step_mm=0.005, bin_px=8.0, azimuths=8)
    return tolerance_context(paper_mirror, from_config(cfg), Program.BEST, 300.0)


def _figures(ctx, trials):
    fig = evaluate_trials(ctx, trials, chunk=10)  # 6 blocks of 10 trials for 2 workers
    flat = {f"raw.{k}": v for k, v in fig.raw.items()} | {f"cal.{k}": v for k, v in fig.calibrated.items()}
    flat |= {"slope": fig.slope_error_rad_rms, "ndev": fig.normal_deviation_mm_rms, "lost": fig.lost_fraction,
             "rot": fig.calibration.rotation, "coeffs": fig.calibration.coeffs}
    passed = judge(fig, ctx.limits, ctx.settings.spec.calibrated)
    return flat, float(np.mean(np.all(np.stack(list(passed.values())), axis=0)))


def test_serial_processes_and_dask_give_the_same_figures_and_yield(ctx):
    from dask.distributed import LocalCluster

    trials = draw_trials(ctx, 60, seed=11)
    ctx.ensure(trials)
    serial, y1 = _figures(ctx, trials)
    with compute.session(workers=2) as ex:
        assert ex.kind == "processes"
        local, y2 = _figures(ctx, trials)
    with LocalCluster(processes=False, n_workers=2, threads_per_worker=1, protocol="tcp", host="127.0.0.1",
                      dashboard_address=None) as cluster:
        with compute.session(scheduler=cluster.scheduler_address) as ex:
            assert ex.kind == "dask"
            dask, y3 = _figures(ctx, trials)
    assert compute.active().kind == "serial"
    assert 0.0 < y1 < 1.0 and y1 == y2 == y3
    for key, v in serial.items():
        assert np.array_equal(v, local[key], equal_nan=True), key
        assert np.array_equal(v, dask[key], equal_nan=True), key


def test_a_worker_error_reaches_the_parent_and_the_pool_ends():
    with compute.session(workers=2) as ex:
        with pytest.raises(ZeroDivisionError):
            with ex.bound(1.0) as run:
                run.map(_divide, [1, 0, 3])
        with ex.bound(2) as run:
            assert run.map(_divide, [1, 2, 4, 8]) == [2.0, 1.0, 0.5, 0.25]


@pytest.mark.parametrize("n, unit, workers, sizes", [
    (2000, 100, 2, [500] * 4),            # 20 batches: 2 rounds of 2 blocks, not 5 of 400 (3 rounds)
    (2000, 100, 4, [200, 300] * 4),       # 8 blocks of 2 or 3 batches: 2 rounds of at most 3
    (55, 10, 2, [10] * 5 + [5]),          # 6 units: 6 blocks, 3 rounds of one (4 blocks: 2 of 2 units); the last short
    (5, 100, 4, [5]),
    (1_000_000, 100, 64, None),           # 10,000 units: 128 blocks of 78 or 79 (2 rounds of 64)
])
def test_blocks_are_whole_units_that_keep_every_worker_busy(n, unit, workers, sizes):
    got = compute.blocks(n, unit, workers)
    assert got[0].start == 0 and got[-1].stop == n and all(a.stop == b.start for a, b in zip(got, got[1:]))
    assert all(s.start % unit == 0 for s in got)
    if sizes is not None:
        assert [s.stop - s.start for s in got] == sizes
    else:  # 128 x 78 = 9,984 units: 16 blocks of 79 (16 x 79 + 112 x 78 = 10,000)
        assert len(got) == 128 and sum(s.stop - s.start == 7900 for s in got) == 16
        assert {s.stop - s.start for s in got} == {7800, 7900}


def _divide(shared, item):
    return shared / item


def _trials_in_background(n):
    """A background task that runs its own pool (nested: 2 processes of its own)."""
    with compute.active().bound(n) as run:
        return run.map(_divide, [1, 2, 4])


def test_a_background_task_runs_beside_the_caller_with_its_own_pool():
    with compute.session(workers=2) as ex:
        with ex.background(_trials_in_background, 8.0) as job:
            mine = [_divide(8.0, k) for k in (1, 2, 4)]
            assert job.result() == mine == [8.0, 4.0, 2.0]
        with pytest.raises(ZeroDivisionError):
            with ex.background(_trials_in_background, 1.0):
                raise ZeroDivisionError("the caller fails: the task is killed")
    with compute.Executor(1).background(_trials_in_background, 4.0) as job:
        assert job.result() == [4.0, 2.0, 1.0]


def test_tolerance_cli_on_a_dask_scheduler_gives_the_local_yield(tmp_path):
    """120 trials: two batches of 100 and 20 (the local run on 2 processes splits them the
    same way); the Dask workers are threads of this test's process, over TCP."""
    from dask.distributed import LocalCluster

    cfg = tmp_path / "q.toml"
    cfg.write_text(QUICK.format(trials=120))
    local = run_cli("tolerance", "--config", str(cfg), "--json", "--no-progress", "--workers", "2")
    assert local.returncode == 0, local.stderr[-2000:]
    with LocalCluster(processes=False, n_workers=2, threads_per_worker=1, protocol="tcp",
                      host="127.0.0.1", dashboard_address=None) as cluster:
        remote = run_cli("tolerance", "--config", str(cfg), "--json", "--no-progress",
                         "--scheduler", cluster.scheduler_address)
    assert remote.returncode == 0, remote.stderr[-2000:]
    a, b = json.loads(local.stdout), json.loads(remote.stdout)
    mc_a, mc_b = a["programs"]["best"]["monte_carlo"], b["programs"]["best"]["monte_carlo"]
    assert mc_a["trials"] == 120 and mc_a["yield"] == mc_b["yield"]
    assert a == b


@pytest.mark.parametrize("args, msg", [
    (["--workers", "-1"], "--workers"),
    (["--workers", "1025"], "--workers"),
    (["--scheduler", "localhost"], "--scheduler 'localhost': not a scheduler address; allowed a Dask scheduler's "
                                   "tcp://HOST:PORT"),
    (["--scheduler", "tls://127.0.0.1:8786"], "--scheduler 'tls://127.0.0.1:8786': protocol tls:// is not supported"),
    (["--scheduler", "ucx://127.0.0.1:8786"], "protocol ucx:// is not supported"),
    (["--scheduler", "inproc://10.0.0.1/1234/1"], "protocol inproc:// is not supported"),
    (["--scheduler", "ws://127.0.0.1:8786"], "protocol ws:// is not supported"),
    (["--scheduler", "tcp://127.0.0.1:70000"], "port 1 .. 65535"),
    (["--scheduler", "tcp://a\x1b[2J:1"], r"'tcp://a\x1b[2J:1': not a scheduler address"),
    (["--scheduler", "tcp://127.0.0.1:9"], "--scheduler tcp://127.0.0.1:9: cannot reach the Dask scheduler"),
])
def test_bad_compute_flags_exit_2_writing_nothing(tmp_path, args, msg):
    cfg = tmp_path / "q.toml"
    cfg.write_text(QUICK.format(trials=120))
    out = tmp_path / "out"
    proc = run_cli("tolerance", "--config", str(cfg), "-o", str(out), "--no-progress", *args)
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and msg in lines[0], proc.stderr
    assert not out.exists()


# --------------------------------------------------------------------------------------
# Signals to the process group of a command running a pool


def _group(pgid: int) -> list[int]:
    """Live (not zombie) processes of a process group, from /proc."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[2]) == pgid and fields[0] != "Z":
            out.append(int(entry))
    return out


@pytest.mark.parametrize("command, extra", [
    ("optimize", ["--config", "{cfg_opt}", "-o", "{out}.toml"]),
    ("tolerance", ["--config", "{cfg_tol}", "-o", "{out}"]),
])
@pytest.mark.parametrize("sig, status, word", [(signal.SIGINT, 130, "interrupted"),
                                               (signal.SIGTERM, 143, "terminated")])
def test_a_group_signal_ends_the_pool_within_a_second(tmp_path, command, extra, sig, status, word):
    (tmp_path / "opt.toml").write_text("[optimize]\nmaxiter = 400\npopsize = 30\n")
    (tmp_path / "tol.toml").write_text(QUICK.format(trials=600))
    out = tmp_path / "out"
    argv = [a.format(cfg_opt=tmp_path / "opt.toml", cfg_tol=tmp_path / "tol.toml", out=out) for a in extra]
    proc = subprocess.Popen([sys.executable, "-m", "lathe_mirror", command, *argv, "--workers", "2",
                             "--no-progress"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while len(_group(proc.pid)) < 3:  # the command and its two workers
            assert proc.poll() is None, proc.stderr.read()[-2000:]
            assert time.monotonic() < deadline, "the pool never started"
            time.sleep(0.02)
        time.sleep(0.2)  # mid-run
        os.killpg(proc.pid, sig)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=30)
        elapsed = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == status, err[-2000:]
    assert err.strip().splitlines() == [f"lathe-mirror: {word}"], err
    assert elapsed < 1.5, elapsed
    assert _group(proc.pid) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["opt.toml", "tol.toml"]  # nothing written
