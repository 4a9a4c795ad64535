"""Every signal that ends the process (SIGHUP, SIGQUIT, SIGINT, SIGTERM), timed into a
command's writes in a real process: before the last rename it leaves no temporary
(`.*.part`), no link (`.*.old`), the old file's bytes and exit 128 + the signal's number;
during the renames it is held until the last one (the command succeeded: status 0, every
file new). An interrupted `run` leaves no process, zombie or not, behind it."""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

OLD = b'{"old": true}\n'
SPEC_FILES = ["mirror_drawing.pdf", "mirror_drawing.svg", "mirror_spec.json"]
NAMES = {signal.SIGINT: "lathe-mirror: interrupted", signal.SIGTERM: "lathe-mirror: terminated",
         signal.SIGHUP: "lathe-mirror: terminated (SIGHUP)", signal.SIGQUIT: "lathe-mirror: terminated (SIGQUIT)"}

# The command as a program (cli.main() without arguments, as the console script runs it),
# with a hook that sends the signal to the process itself at a chosen moment of the writes:
# after a temporary's bytes are written (its fsync), or after an old file's link is made
# (between two renames).
PROGRAM = """
import os, sys
from lathe_mirror.export import files
sig, when = int(sys.argv[1]), sys.argv[2]
if when == "temporary":
    fsync = os.fsync
    def hooked(fd):
        fsync(fd)
        os.kill(os.getpid(), sig)
    os.fsync = hooked
elif when == "link":
    keep = files._keep_old
    def hooked(target):
        link = keep(target)
        os.kill(os.getpid(), sig)
        return link
    files._keep_old = hooked
elif when == "slow":  # a slow disk: the signal comes from outside (the test)
    import time
    fsync = os.fsync
    def hooked(fd):
        time.sleep(0.5)
        fsync(fd)
    os.fsync = hooked
from lathe_mirror.cli import main
sys.argv = ["lathe-mirror", "spec", "-o", "S"]
sys.exit(main())
"""


#: The program's process is forked from one that has imported what `spec` imports (a clean
#: interpreter, no thread, no handler of its own: not this test process): a process of its
#: own as the console script's, without an interpreter's start-up and imports each time
#: (1.6 s of the 4.5 s of CPU a fresh one took).
ZYGOTE = """
import importlib, os, sys
for name in sys.argv[1].split(","):
    importlib.import_module(name)
program = sys.argv[2]
for line in sys.stdin:
    cwd, sig, when, err = line.rstrip("\\n").split("\\t")
    pid = os.fork()
    if pid == 0:
        os.chdir(cwd)
        fd = os.open(err, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fd, 2)
        null = os.open(os.devnull, os.O_RDWR)
        os.dup2(null, 0)
        os.dup2(null, 1)
        os.close(fd)
        os.close(null)
        sys.argv = ["-c", sig, when]
        exec(compile(program, "<program>", "exec"), {"__name__": "__main__"})
        os._exit(70)  # not reached: the program exits
    print(pid, flush=True)
    print(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), flush=True)
"""
PRELOAD = ("lathe_mirror.cli", "lathe_mirror.commands.spec", "lathe_mirror.commands.common", "lathe_mirror.iso10110",
           "lathe_mirror.body", "lathe_mirror.export.drawing", "lathe_mirror.export.files",
           "matplotlib.backends.backend_pdf", "matplotlib.backends.backend_svg")


@pytest.fixture(scope="module")
def zygote():
    proc = subprocess.Popen([sys.executable, "-c", ZYGOTE, ",".join(PRELOAD), PROGRAM], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, bufsize=0)
    yield proc
    proc.stdin.close()
    proc.wait(timeout=60)


class Forked:
    """The program forked by the zygote, with the part of Popen's interface the tests use:
    its pid (signals go to it alone), its exit status (-N: killed by signal N), its stderr."""

    def __init__(self, zygote: subprocess.Popen, tmp_path: Path, sig: int, when: str):
        self._zygote, self._err, self._buffer = zygote, tmp_path / "stderr.txt", b""
        zygote.stdin.write(f"{tmp_path}\t{int(sig)}\t{when}\t{self._err}\n".encode())
        self.pid = int(self._line(60.0))
        self.returncode = None

    def _line(self, timeout: float) -> str | None:
        """The zygote's next line, or None if none came within timeout seconds."""
        fd, deadline = self._zygote.stdout.fileno(), time.monotonic() + timeout
        while b"\n" not in self._buffer:
            ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                return None
            chunk = os.read(fd, 64)
            assert chunk, "the zygote ended"
            self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line.decode()

    def poll(self) -> int | None:
        if self.returncode is None and (line := self._line(0.0)) is not None:
            self.returncode = int(line)
        return self.returncode

    def communicate(self, timeout: float) -> tuple[None, str]:
        if self.returncode is None:
            line = self._line(timeout)
            if line is None:
                raise subprocess.TimeoutExpired("spec", timeout)
            self.returncode = int(line)
        return None, self.stderr()

    def stderr(self) -> str:
        return self._err.read_text() if self._err.exists() else ""

    def send_signal(self, sig: int) -> None:
        os.kill(self.pid, sig)

    def kill(self) -> None:
        with contextlib.suppress(ProcessLookupError):  # ended (and reaped) since the last poll
            os.kill(self.pid, signal.SIGKILL)

    def wait(self) -> int:
        self.communicate(60.0)
        return self.returncode


def _spec(zygote, tmp_path: Path, sig: int, when: str) -> Forked:
    (tmp_path / "S").mkdir()
    (tmp_path / "S" / "mirror_spec.json").write_bytes(OLD)
    return Forked(zygote, tmp_path, sig, when)


def _left(tmp_path: Path) -> list[str]:
    return sorted(p.name for p in (tmp_path / "S").iterdir())


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGQUIT, signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_a_temporary_is_written_leaves_the_old_file_alone(zygote, tmp_path, sig):
    proc = _spec(zygote, tmp_path, sig, "temporary")
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 128 + sig, err[-2000:]
    assert err.strip().splitlines() == [NAMES[sig]], err
    assert _left(tmp_path) == ["mirror_spec.json"] and (tmp_path / "S" / "mirror_spec.json").read_bytes() == OLD


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGQUIT])
def test_a_signal_between_two_renames_is_held_until_the_last(zygote, tmp_path, sig):
    proc = _spec(zygote, tmp_path, sig, "link")
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0 and err == "", err[-2000:]
    assert _left(tmp_path) == SPEC_FILES
    assert (tmp_path / "S" / "mirror_spec.json").read_bytes() != OLD


def test_a_hangup_from_outside_as_the_first_temporary_appears(zygote, tmp_path):
    """Issue 35's case: SIGHUP (a closed terminal) as the first `.part` shows."""
    proc = _spec(zygote, tmp_path, signal.SIGHUP, "slow")
    try:
        deadline = time.monotonic() + 300
        while not any(n.endswith(".part") for n in os.listdir(tmp_path / "S")):
            assert proc.poll() is None, proc.stderr()[-2000:]
            assert time.monotonic() < deadline, "no temporary appeared"
            time.sleep(0.005)
        proc.send_signal(signal.SIGHUP)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 129, err[-2000:]
    assert err.strip().splitlines() == [NAMES[signal.SIGHUP]], err
    assert _left(tmp_path) == ["mirror_spec.json"] and (tmp_path / "S" / "mirror_spec.json").read_bytes() == OLD


def _group(pgid: int) -> list[tuple[int, str, int]]:
    """(pid, state, parent pid) of every process of a process group, zombies included."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[2]) == pgid:
            out.append((int(entry), fields[0], int(fields[1])))
    return out


QUICK_RUN = ("[polish]\ncurve_points = 3\n[tolerance]\ntrials = 2000\nlattice_phases = 1\nnose_step_mm = 0.005\n"
             "programs = [\"best\"]\n")


def test_an_interrupted_run_leaves_no_process_zombie_or_not(tmp_path):
    """SIGINT to `run`'s process group while its background tolerance analysis runs its
    own pool (a grandchild of the command): when the command has exited, no process of
    the group is left, not even a zombie handed to init (issue 35: two for ~1.5 s)."""
    (tmp_path / "q.toml").write_text(QUICK_RUN)
    proc = subprocess.Popen([sys.executable, "-m", "lathe_mirror", "run", "--config", "q.toml", "-o", "out",
                             "--no-render", "--workers", "2", "--no-progress"], cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 600
        while not any(ppid not in (proc.pid, 1) for pid, _, ppid in _group(proc.pid) if pid != proc.pid):  # a worker's worker
            assert proc.poll() is None, proc.stderr.read()[-2000:]
            assert time.monotonic() < deadline, "the background pool never started"
            time.sleep(0.02)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        left = _group(proc.pid)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130 and err.strip() == "lathe-mirror: interrupted", err[-2000:]
    assert left == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["q.toml"]
