"""Issue 24: the second round of the hostile user's fuzz. Each numbered case of the issue
with its input: special files as inputs, outputs that commit as a set (a full disk, a
failed rename, a signal before and after the last rename), flag ranges, output suffixes,
a hand-edited program for `toolpath --check`.

Bad input: exit 2, one line on stderr naming the input, no traceback, nothing written and
nothing replaced, bounded time and memory. Signals: 130 / 143 and nothing left, or, after
the last rename, success with the files in place.
"""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from test_bounds import cli, files_under

#: A configuration that is not the paper's: a 0.4 mm nose (the junction still reachable).
NOSE04 = "[tool]\nnose_radius = 0.4\n"
#: A process of ours may use at most this much address space (bytes) reading a hostile input.
MEMORY_CAP = 2 << 30


def refused(tmp_path: Path, *args: str, within: float = 20.0) -> str:
    before = files_under(tmp_path)
    rc, out, err, seconds = cli(*args, cwd=tmp_path)
    assert rc == 2, (rc, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert files_under(tmp_path) == before
    assert seconds < within, seconds
    return lines[0]


def capped(cmd: str, tmp_path: Path, timeout: float = 20.0) -> subprocess.CompletedProcess:
    """`cmd` in bash, its address space capped at MEMORY_CAP (an unbounded read fails with
    MemoryError instead of growing), within timeout seconds (a hang fails the test)."""
    exe = f"{sys.executable} -m lathe_mirror"
    return subprocess.run(["bash", "-c", f"ulimit -v {MEMORY_CAP // 1024}; {cmd.replace('LM', exe)}"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=timeout)


# --------------------------------------------------------------------------------------
# 1. Special files as inputs


@pytest.mark.parametrize("config, kind", [("/dev/zero", "character device"), ("<(yes '#')", "FIFO or pipe"),
                                          ("FIFO", "FIFO or pipe"), ("/dev/null", "character device")])
def test_a_special_file_as_config_is_one_line_at_once(tmp_path, config, kind):
    """/dev/zero grew to 24 GB; <(yes '#') ran out of memory; a FIFO blocked forever."""
    os.mkfifo(tmp_path / "FIFO")
    proc = capped(f"LM design --config {config}", tmp_path, timeout=20)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert f"is a {kind}, not a regular file" in proc.stderr and "--config" in proc.stderr


def test_standard_input_when_asked_for_bounded_while_reading(tmp_path):
    """`--config -` reads stdin (a 0.4 mm nose reaches the figures); an endless stdin is
    refused at the limit, in bounded memory and time."""
    ok = subprocess.run([sys.executable, "-m", "lathe_mirror", "toolpath", "--config", "-", "--json"],
                        input=NOSE04, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert ok.returncode == 0, ok.stderr
    assert '"nose_radius_mm": 0.4' in ok.stdout
    proc = capped("yes '#' | LM design --config -", tmp_path)
    assert proc.returncode == 2 and "--config -: more than 1048576 bytes" in proc.stderr, proc.stderr


def test_a_proc_file_that_stats_as_empty_is_read_within_the_limit(tmp_path):
    """/proc files report size 0: the limit holds while reading (here: it is not TOML)."""
    line = refused(tmp_path, "design", "--config", "/proc/self/status")
    assert "--config /proc/self/status: not valid TOML" in line


def test_a_signal_interrupts_a_read(tmp_path):
    """SIGTERM while the config is read from a stdin that never ends: 143, at once."""
    proc = subprocess.Popen(["bash", "-c", f"exec {sys.executable} -m lathe_mirror design --config - "
                             "< <(exec sleep 30 2>/dev/null)"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    import time

    t0 = time.monotonic()
    while not _catches_sigterm(proc.pid) and time.monotonic() - t0 < 60:  # main() has started
        time.sleep(0.05)
    time.sleep(0.3)  # ... and waits on the read
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=5)
    assert proc.returncode == 143 and err.strip() == "lathe-mirror: terminated", err


def _catches_sigterm(pid: int) -> bool:
    """Whether the process has a handler for SIGTERM (cli.main installs it)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = int(next(ln.split()[1] for ln in status.splitlines() if ln.startswith("SigCgt:")), 16)
    return bool(caught & (1 << (signal.SIGTERM - 1)))


def test_read_input_unit(tmp_path):
    from lathe_mirror.errors import InputError
    from lathe_mirror.inputs import check_input, check_number, read_input

    f = tmp_path / "a.txt"
    f.write_bytes(b"x" * 100)
    assert read_input(f, "--in", 100) == b"x" * 100
    with pytest.raises(InputError, match=r"^--in .*a.txt: 100 bytes; allowed at most 99 bytes$"):
        read_input(f, "--in", 99)
    with pytest.raises(InputError, match="is a directory"):
        check_input(tmp_path, "--in", 10)
    for bad in (float("nan"), float("inf"), "1e999"):
        with pytest.raises(InputError, match="must be a finite number"):
            check_number(bad, "p.ngc line 3: X")
    with pytest.raises(InputError, match=r"^p.ngc line 3: X = 61 mm: allowed 0 to 60 mm$"):
        check_number(61, "p.ngc line 3: X", 0, 60, "mm")


# --------------------------------------------------------------------------------------
# 3, 4. Outputs commit as a set


def _enospc_on_call(monkeypatch, n: int):
    """os.fsync of export.files raises ENOSPC at its n-th call of every two (a disk that
    fills up while a two-file command's n-th file is written)."""
    from lathe_mirror.export import files

    calls = []
    real = os.fsync

    def fsync(fd):
        calls.append(fd)
        if (len(calls) - 1) % 2 == n - 1:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)

    monkeypatch.setattr(files.os, "fsync", fsync)
    return calls


@pytest.mark.parametrize("n", [1, 2])
def test_a_full_disk_leaves_no_file_and_replaces_none(tmp_path, monkeypatch, n):
    """Simulated ENOSPC on the program (1) or on its set-up sheet (2): exit 2 naming the
    file, no keep.setup.html, and the existing keep.ngc keeps its bytes."""
    (tmp_path / "c.toml").write_text(NOSE04)
    (tmp_path / "keep.ngc").write_text("old program\n")
    _enospc_on_call(monkeypatch, n)
    line = refused(tmp_path, "toolpath", "--config", "c.toml", "-o", "keep.ngc", within=120)
    assert "No space left on device" in line and "-o/--output" in line
    assert (tmp_path / "keep.ngc").read_text() == "old program\n"
    assert files_under(tmp_path) == {"c.toml", "keep.ngc"}


def test_a_full_tmpfs(tmp_path):
    """The issue's own case: a 64 KiB tmpfs (the set-up sheet alone is ~100 KB)."""
    d = tmp_path / "small"
    d.mkdir()
    try:
        subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(d)], check=True,
                       capture_output=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        pytest.skip(f"cannot mount a tmpfs here ({exc})")
    try:
        (d / "keep.ngc").write_text("old program\n")
        for name in ("t.ngc", "keep.ngc"):
            rc, out, err, _ = cli("toolpath", "-o", str(d / name), cwd=tmp_path)
            assert rc == 2 and "No space left on device" in err and err.count("\n") == 1, err
        assert sorted(p.name for p in d.iterdir()) == ["keep.ngc"]
        assert (d / "keep.ngc").read_text() == "old program\n"
    finally:
        subprocess.run(["umount", str(d)], check=False)


def test_a_failed_rename_puts_back_the_files_already_replaced(tmp_path, monkeypatch):
    from lathe_mirror.errors import InputError
    from lathe_mirror.export import files

    (tmp_path / "a.txt").write_text("old a\n")
    real, calls = os.replace, []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(InputError, match="b.txt: cannot write"):
        with files.staging():
            files.write_text(tmp_path / "a.txt", "new a\n")
            files.write_text(tmp_path / "b.txt", "new b\n")
    assert files_under(tmp_path) == {"a.txt"}
    assert (tmp_path / "a.txt").read_text() == "old a\n"


@pytest.mark.parametrize("when, status", [("write", 143), ("rename", 0)])
def test_a_signal_before_the_last_rename_leaves_nothing_after_it_everything(tmp_path, monkeypatch, when, status):
    """SIGTERM while the files are written: 143, no file, keep.ngc's bytes. SIGTERM during
    the renames (held until the last one): the command succeeded, status 0, files there."""
    from lathe_mirror.export import files

    (tmp_path / "keep.ngc").write_text("old program\n")
    hook = "_write_temp" if when == "write" else "_keep_old"  # the latter: between two renames
    real = getattr(files, hook)

    def signalled(*a, **k):
        os.kill(os.getpid(), signal.SIGTERM)
        return real(*a, **k)

    monkeypatch.setattr(files, hook, signalled)
    rc, out, err, _ = cli("toolpath", "-o", "keep.ngc", cwd=tmp_path)
    assert rc == status, err
    if status:
        assert err.strip() == "lathe-mirror: terminated"
        assert files_under(tmp_path) == {"keep.ngc"} and (tmp_path / "keep.ngc").read_text() == "old program\n"
    else:
        assert files_under(tmp_path) == {"keep.ngc", "keep.setup.html", "keep_op2.ngc", "tools.tbl"}  # both set-ups, the table
        assert (tmp_path / "keep.ngc").read_text().startswith("%\n")


def test_a_signal_after_the_command_settled_does_not_kill_the_process():
    """Run as a program, the process ignores SIGINT / SIGTERM once main is done (a signal
    there used to kill it with -15 / -2 after the files were written)."""
    code = ("import os, signal, sys\n"
            "from lathe_mirror.cli import main\n"
            "sys.argv = ['lathe-mirror', 'design', '--json']\n"
            "rc = main()\n"
            "os.kill(os.getpid(), signal.SIGTERM); os.kill(os.getpid(), signal.SIGINT)\n"
            "sys.exit(rc)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr


# --------------------------------------------------------------------------------------
# 5, 7, 8. Flag ranges, output names and suffixes


def test_every_numeric_flag_has_a_range_shown_by_help_and_the_reference():
    from lathe_mirror.cli import build_parser
    from lathe_mirror.commands.flags import FLAGS, numeric_flags, readme_table
    from lathe_mirror.settings import RANGES

    parser = build_parser()
    found = numeric_flags(parser)
    assert set(found) == set(FLAGS), set(found) ^ set(FLAGS)
    for name, action in found.items():
        assert f"[range {FLAGS[name].text()}]" in action.help, name
        key = FLAGS[name].key
        if key:  # a flag that sets a key has the key's range
            assert (RANGES[key].lo, RANGES[key].hi) == (FLAGS[name].lo, FLAGS[name].hi), name
    assert readme_table() in (Path(__file__).parent.parent / "docs" / "reference" / "commands.md").read_text()


def _just_past(x: float, up: bool) -> str:
    import math

    if isinstance(x, int):
        return str(x + 1 if up else x - 1)
    return repr(math.nextafter(x, math.inf if up else -math.inf) if x else (1e-300 if up else -1e-300))


def test_every_flag_at_its_ends_and_just_past_them():
    """The parser takes each end of each range and refuses one step past it (and NaN) with
    one line naming the flag, exit 2, before any work."""
    import io
    from contextlib import redirect_stderr

    from lathe_mirror.cli import build_parser
    from lathe_mirror.commands.flags import FLAGS

    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.choices and isinstance(a.choices, dict))
    for name, rng in FLAGS.items():
        command, flag = name.split()
        # a command's required positional arguments (measure, compensate: the file)
        positional = ["x" for a in subparsers.choices[command]._actions if not a.option_strings and a.required]
        for end, up in ((rng.lo, False), (rng.hi, True)):
            if end is None:
                continue
            args = parser.parse_args([command, *positional, flag, str(end)])
            assert getattr(args, flag.lstrip("-").replace("-", "_")) == end
            for bad in (_just_past(end, up), "nan") if isinstance(end, float) else (_just_past(end, up),):
                err = io.StringIO()
                with redirect_stderr(err), pytest.raises(SystemExit) as exc:
                    parser.parse_args([command, *positional, f"{flag}={bad}"])
                assert exc.value.code == 2 and err.getvalue().count("\n") == 1, (name, bad)
                assert f"argument {flag}: {bad}" in err.getvalue() and f"allowed {rng.text()}" in err.getvalue()


@pytest.mark.parametrize("value", ["1e-3", "1e-300", "1e200", "1e12", "-inf", "nan", "0"])
def test_calib_range_m_outside_the_scene(tmp_path, value):
    """1e-3 .. 1e-300 exited 1 with LinAlgError, 1e200 with OverflowError; 1e12 was taken."""
    line = refused(tmp_path, "calib", f"--range-m={value}", "--surface", "exact")
    assert line.startswith(f"lathe-mirror calib: error: argument --range-m: {value} m: allowed 0.05 to 1e+06 m, "
                           "or inf (directions)")


def test_calib_range_m_inf_is_directions():
    from lathe_mirror.cli import build_parser

    assert build_parser().parse_args(["calib", "--range-m", "inf"]).range_m == float("inf")


@pytest.mark.parametrize("args, message", [
    (("toolpath", "-o", "x.step"), "-o/--output x.step: a '.step' file cannot hold G-code; name it *.ngc"),
    (("toolpath", "-o", "x.ngc.png"), "a '.png' file cannot hold G-code"),
    (("optimize", "-o", "d.png"), "-o/--output d.png: a '.png' file cannot hold TOML; name it *.toml"),
    (("design", "-o", "d.toml"), "-o/--output d.toml: a '.toml' file cannot hold JSON"),
    (("tolerance", "--csv", "t.json"), "--csv t.json: a '.json' file cannot hold CSV"),
    (("tolerance", "--csv", ""), "argument --csv: empty path"),
    (("tolerance", "--csv", "/proc/version"), "--csv /proc/version: cannot write in /proc"),
])
def test_an_output_name_that_cannot_hold_what_is_written(tmp_path, args, message):
    """`toolpath -o x.step` wrote G-code into x.step, `optimize -o d.png` TOML into d.png;
    `tolerance --csv ''` exited 0 writing nothing; --csv /proc/version named -o/--output."""
    (tmp_path / "c.toml").write_text(NOSE04)
    assert message in refused(tmp_path, *args, "--config", "c.toml")


# --------------------------------------------------------------------------------------
# 6. toolpath --check reads a hand-edited program


@pytest.fixture(scope="module")
def nose04_program(tmp_path_factory) -> tuple[Path, list[str]]:
    """The program `toolpath` writes for the 0.4 mm nose config (not the paper's), and its
    lines; `toolpath --check` accepts it as written."""
    d = tmp_path_factory.mktemp("nose04")
    (d / "c.toml").write_text(NOSE04)
    rc, out, err, _ = cli("toolpath", "--config", "c.toml", "-o", "p.ngc", cwd=d)
    assert rc == 0, err
    rc, out, err, _ = cli("toolpath", "--config", "c.toml", "--check", "p.ngc", cwd=d)
    assert rc == 0 and "no contact at rapid" in out, err
    return d, (d / "p.ngc").read_text().splitlines()


def _first(lines: list[str], prefix: str) -> int:
    return next(i for i, ln in enumerate(lines) if ln.startswith(prefix))


@pytest.mark.parametrize("edit, message", [
    (lambda w: re.sub(r"X[-\d.]+", "Xnan", w), "'XNAN' is not a word of this linuxcnc program"),
    (lambda w: re.sub(r"X[-\d.]+", "Xinf", w), "'XINF' is not a word of this linuxcnc program"),
    (lambda w: re.sub(r"X[-\d.]+", "X1e1", w), "word E1 is not simulated"),
    (lambda w: w + " Y2.0", "word Y2.0 is not simulated"),
    (lambda w: w.split(" X")[0] + " X12345678901234567890 Z-1.000",
     "X12345678901234567890 is outside the machine's travel (radius at most 60 mm"),
    (lambda w: w.split(" X")[0] + " X10.000 Z-80.001", "Z-80.001 is outside the machine's travel (-80 to 60 mm"),
    (lambda w: w.split(" X")[0] + " X" + "9" * 5000, "a number of 5000 characters"),
])
def test_check_refuses_a_bad_word_naming_its_block(tmp_path, nose04_program, edit, message):
    """Xnan was accepted (exit 0); a 20-digit coordinate exited 1 (ValueError)."""
    d, lines = nose04_program
    k = _first(lines, "N9 G1 ")  # the facing cut
    bad = list(lines)
    bad[k] = edit(bad[k])
    (tmp_path / "c.toml").write_text(NOSE04)
    (tmp_path / "e.ngc").write_text("\n".join(bad) + "\n")
    line = refused(tmp_path, "toolpath", "--config", "c.toml", "--check", "e.ngc")
    assert f"--check e.ngc line {k + 1} (N9): " in line and message in line, line


@pytest.mark.parametrize("feed", ["F0", "F-0.1", "F0.0"])
def test_check_refuses_a_zero_or_negative_feed(tmp_path, nose04_program, feed):
    """F0 gave "cycle time inf s" and null in the JSON."""
    d, lines = nose04_program
    k = _first(lines, "N4 F")
    bad = list(lines)
    bad[k] = f"N4 {feed}"
    (tmp_path / "e.ngc").write_text("\n".join(bad) + "\n")
    line = refused(tmp_path, "toolpath", "--check", "e.ngc", "--json")
    assert f"line {k + 1} (N4): {feed.replace('F0.0', 'F0').replace('F-0.1', 'F-0.1')}" in line
    assert "a feed must be above 0 and at most 500 mm/rev" in line


def test_check_refuses_a_feed_move_before_any_feed(tmp_path, nose04_program):
    d, lines = nose04_program
    bad = [ln for ln in lines if not ln.startswith("N4 F")]
    (tmp_path / "e.ngc").write_text("\n".join(bad) + "\n")
    assert "(N9): a feed move before any F word" in refused(tmp_path, "toolpath", "--check", "e.ngc")


def test_check_refuses_a_program_beyond_its_stated_size(tmp_path, nose04_program):
    """A 5.6 MB program ran past 120 s: beyond 2 MiB it is refused unread; beyond 10 000
    moves before the simulation starts."""
    from lathe_mirror.shop.replay import MAX_MOVES, MAX_PROGRAM_BYTES

    d, lines = nose04_program
    head, tail = lines[:_first(lines, "N9 G1 ")], lines[-3:]
    big = tmp_path / "big.ngc"
    big.write_text("\n".join(head + ["G1 X10.000 Z0.350"] * (MAX_PROGRAM_BYTES // 18) + tail) + "\n")
    assert big.stat().st_size > MAX_PROGRAM_BYTES
    line = refused(tmp_path, "toolpath", "--check", "big.ngc", within=10)
    assert f"allowed at most {MAX_PROGRAM_BYTES} bytes" in line
    many = tmp_path / "many.ngc"
    many.write_text("\n".join(head + ["G1 X10.000 Z0.350", "G1 X10.000 Z0.300"] * (MAX_MOVES // 2 + 1) + tail) + "\n")
    assert many.stat().st_size < MAX_PROGRAM_BYTES
    line = refused(tmp_path, "toolpath", "--check", "many.ngc", within=30)
    assert f"more than {MAX_MOVES} moves" in line


@pytest.mark.parametrize("what", ["FIFO", "/dev/zero", "DIR"])
def test_check_refuses_a_special_file_at_once(tmp_path, what):
    os.mkfifo(tmp_path / "FIFO")
    (tmp_path / "DIR").mkdir()
    line = refused(tmp_path, "toolpath", "--check", what, within=10)
    assert line.startswith(f"lathe-mirror toolpath: error: --check {what}: is ")


def test_a_signal_whose_exception_python_swallows_is_delivered_again():
    """SIGTERM landing in a weakref callback: Python ignores the exception the handler
    raises there ("Exception ignored in ..."), and `run` went on for minutes after the
    signal. The signal is delivered again within about a second; nothing is printed."""
    import io
    import time
    import weakref
    from contextlib import redirect_stderr

    from lathe_mirror.cli import Terminated, _signals_raise

    class Part:
        pass

    received: list[int] = []
    err = io.StringIO()
    t0 = time.monotonic()
    with redirect_stderr(err), pytest.raises(Terminated):
        with _signals_raise(received):
            part = Part()
            ref = weakref.ref(part, lambda _: os.kill(os.getpid(), signal.SIGTERM))
            del part  # the callback runs; the handler raises inside it; Python swallows that
            while time.monotonic() - t0 < 10:
                time.sleep(0.01)
    assert ref() is None and received[:2] == [signal.SIGTERM, signal.SIGTERM]
    assert time.monotonic() - t0 < 5 and err.getvalue() == ""


# --------------------------------------------------------------------------------------
# 35.11. Bytes from a file reach the terminal only escaped


ESCAPES = b"\x1b[2J\x1b]0;owned\x07\x1b[31mred\x9b1m\xe2\x80\xae\xff"


@pytest.mark.parametrize("name, data", [
    ("trace.plu", ESCAPES + b" garbage\n"),                  # surfalize quotes the line it cannot parse
    ("trace\x1b[2J.csv", b"x,z\n1,2\n"),                     # the file's name itself
])
def test_a_file_s_control_bytes_are_shown_escaped_in_the_error_line(tmp_path, name, data):
    (tmp_path / name).write_bytes(data)
    rc, _, err, _ = cli("measure", name, cwd=tmp_path)
    assert rc == 2, err[-2000:]
    line = err.rstrip("\n")
    assert "\n" not in line and line.isprintable(), repr(line)  # no control, format or surrogate character
    assert "\\x1b[2J" in line


def test_escaped_writes_what_a_terminal_acts_on_as_escapes():
    from lathe_mirror.errors import escaped

    text = ESCAPES.decode("utf-8", "surrogateescape")  # how a file's undecodable bytes arrive
    assert escaped(text) == "\\x1b[2J\\x1b]0;owned\\x07\\x1b[31mred\\x9b1m\\u202e\\xff"
    assert escaped("r = 2.5 mm, é ü 中 ok") == "r = 2.5 mm, é ü 中 ok"
