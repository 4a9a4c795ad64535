"""The `lathe-mirror` command line: parse, call the API, print, set the exit status.

Each subcommand lives in `lathe_mirror.commands.<name>` with `register(subparsers)`;
those modules import nothing heavy at import time, so `--help` and `design` start fast.
Exit status: 0 success, 2 bad input (one line on stderr), 1 internal failure, 128 + the
signal's number when a signal ended it (130 SIGINT, 143 SIGTERM, 129 SIGHUP, 131 SIGQUIT:
errors.ENDING_SIGNALS). A command writes its files only when it succeeds
(export.files.staging), all of them or none: on any failure or signal before the last
rename it leaves nothing behind; a signal after it leaves the files and the status says
success. Run as a program (`main()` without arguments), the process ignores those signals
once the command's outcome is settled, so a signal during the interpreter's exit cannot
kill it with a status that contradicts the files. Every message is printed with the
control characters of its text escaped (a file's bytes quoted in an error cannot drive
the terminal).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
import threading
import traceback
import warnings

from .version import __version__
from .errors import ENDING_SIGNALS, InputError, escaped

COMMANDS = ("design", "toolpath", "cad", "render", "polish", "tolerance", "calib", "stereo", "report", "run",
            "optimize", "spec", "measure", "compensate")


class _Parser(argparse.ArgumentParser):
    """argparse with the one-line error of every other bad input (no usage block)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {escaped(message)} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="lathe-mirror",
        description="Design a double-lobed hyperbolic mirror for an omnidirectional camera, "
        "turn it on a CNC lathe within its limits, and predict what the made mirror does "
        "to the image and to stereo depth.",
    )
    parser.add_argument("--version", action="version", version=f"lathe-mirror {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        modname = f"lathe_mirror.commands.{name}"
        try:
            module = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name == modname:
                continue  # a stage not built yet
            raise
        module.register(sub)
    from .commands import flags

    flags.apply(parser)  # every numeric flag's range, checked at parsing and shown by --help
    return parser


#: Set once the command has caught the exception a signal raised (its status is decided):
#: later signals are only noted, and _watch stops delivering.
_handled = threading.Event()


class Terminated(BaseException):
    """SIGTERM, SIGHUP or SIGQUIT, raised in the main thread like KeyboardInterrupt for
    SIGINT, so that a terminated command cleans up as an interrupted one does."""

    def __init__(self, signum: int = 15) -> None:
        super().__init__(signum)
        self.signum = signum


def _ended(signum: int) -> str:
    """The line a command ended by signum prints."""
    import signal

    word = "interrupted" if signum == signal.SIGINT else "terminated"
    if signum in (signal.SIGINT, signal.SIGTERM):
        return f"lathe-mirror: {word}"
    return f"lathe-mirror: {word} ({signal.Signals(signum).name})"


def main(argv: list[str] | None = None) -> int:
    received: list[int] = []  # signals caught: one may surface as another exception
    _handled.clear()
    # From the start (the commands' modules import while the parser is built): a signal
    # at any point is exit 130 / 143 and one line.
    with _signals_raise(received, _committed, settle=argv is None):
        status = _parse_and_run(argv, received)
    if argv is None and received and status == 128 + received[0]:
        # Interrupted, nothing written, the line printed: exit now. (CPython kills itself
        # with SIGINT at exit, status -2, when a KeyboardInterrupt passed through code an
        # extension module runs while it imports, even though it was caught.)
        _exit_now(status)
    return status


def _committed() -> bool:
    """export.files.committed(), if the module has been imported (else nothing is)."""
    files = sys.modules.get("lathe_mirror.export.files")
    return files is not None and files.committed()


def _parse_and_run(argv: list[str] | None, received: list[int]) -> int:
    try:
        args = build_parser().parse_args(argv)
    except (KeyboardInterrupt, Terminated, ImportError):
        if not received:
            raise
        _handled.set()
        print(_ended(received[0]), file=sys.stderr)
        return 128 + received[0]
    return _run(args, received)


def _exit_now(status: int) -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(status)


def _run(args: argparse.Namespace, received: list[int]) -> int:
    """The command, inside main's signal handlers: its files staged and committed."""
    from .export import files

    debug = bool(os.environ.get("LATHE_MIRROR_DEBUG"))
    with warnings.catch_warnings():
        if not debug:
            # numpy's RuntimeWarnings (overflow, 0/0) are expected where a stage probes a
            # surface's edge; they never reach the user's stderr (LATHE_MIRROR_DEBUG shows them).
            warnings.simplefilter("ignore", RuntimeWarning)
        try:
            with files.staging():  # every file written at the end, or none (export.files)
                try:
                    status = int(args.func(args) or 0)
                except BrokenPipeError:  # the reader of stdout left: the work is done
                    status = 0
            return status
        except InputError as exc:
            print(f"lathe-mirror {args.command}: error: {_one_line(exc)}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            _handled.set()
            print(_ended(2), file=sys.stderr)
            return 130
        except Terminated as exc:
            _handled.set()
            print(_ended(exc.signum), file=sys.stderr)
            return 128 + exc.signum
        except BrokenPipeError:
            return 0
        except Exception as exc:  # an internal failure: say so, keep the trace on request
            if received:  # e.g. SIGTERM inside an extension module's import: ImportError
                _handled.set()
                print(_ended(received[0]), file=sys.stderr)
                return 128 + received[0]
            return _internal(args, exc, debug)
        finally:
            _shutdown_compute()


def _shutdown_compute() -> None:
    """Close the command's executor (compute.activate), if the command made one: its
    worker processes are gone already (each pool ends with its map block)."""
    mod = sys.modules.get("lathe_mirror.compute")
    if mod is not None:
        with contextlib.suppress(Exception):
            mod.shutdown()


def _internal(args: argparse.Namespace, exc: BaseException, debug: bool) -> int:
    if debug:
        traceback.print_exception(exc)
    print(f"lathe-mirror {args.command}: internal error: {type(exc).__name__}: {_one_line(exc)} "
          "(set LATHE_MIRROR_DEBUG=1 for the traceback)", file=sys.stderr)
    return 1


def _one_line(exc: BaseException) -> str:
    """The message on one line, at most 1000 characters, its control characters escaped
    (errors.escaped: the message may quote a file's bytes)."""
    text = escaped(" ".join(str(exc).split()))
    return text if len(text) <= 1000 else text[:997] + "..."


@contextlib.contextmanager
def _signals_raise(received: list[int], done=lambda: False, *, settle: bool = False):
    """Within the block SIGINT raises KeyboardInterrupt and SIGTERM, SIGHUP, SIGQUIT
    Terminated in the main thread, each noted in `received`, until done() says the
    command's files are in place (then a signal is only noted). The handlers are restored
    after; with settle, the signals are ignored after instead (the process is about to
    exit with its status)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    stop = threading.Event()  # the block has ended: no more re-deliveries

    def handler(signum, frame):
        received.append(signum)
        if done():  # after the last rename: the command has succeeded
            return
        files = sys.modules.get("lathe_mirror.export.files")
        if files is not None and files.defer_signal(signum):  # renaming: raised again after
            return
        if _handled.is_set() or _raising(threading.main_thread().ident):  # the first one is on its way out
            return
        if len(received) == 1:
            _watch(signum, stop)
        raise KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)

    def unraisable(info):  # the handler's exception swallowed (see _watch): no traceback
        if not isinstance(info.exc_value, (KeyboardInterrupt, Terminated)):
            hook(info)

    hook, sys.unraisablehook = sys.unraisablehook, unraisable
    previous = {sig: signal.signal(sig, handler) for sig in (getattr(signal, n) for n in ENDING_SIGNALS)}
    try:
        yield
    finally:
        stop.set()
        for sig, old in previous.items():
            signal.signal(sig, signal.SIG_IGN if settle else old)
        sys.unraisablehook = hook


def _raising(thread_id: int | None) -> bool:
    """Whether the thread is handling a KeyboardInterrupt or Terminated (in an except or
    finally clause on its way out)."""
    exc = sys._current_exceptions().get(thread_id) if thread_id is not None else None
    if isinstance(exc, tuple):  # Python 3.11: exc_info
        exc = exc[1]
    return isinstance(exc, (KeyboardInterrupt, Terminated))


def _watch(signum: int, stop) -> None:
    """Deliver signum to the main thread again every second until main's block ends, while
    it is not handling the exception the handler raised: an exception raised where Python
    swallows it (a weakref callback, a __del__: "Exception ignored in ...") would otherwise
    lose the signal and the command would run on."""
    import signal
    import threading

    main_id = threading.main_thread().ident

    def watch():
        while not stop.wait(1.0):
            if not (_handled.is_set() or _raising(main_id)):
                signal.pthread_kill(main_id, signum)

    threading.Thread(target=watch, name="lathe-mirror-signal", daemon=True).start()


if __name__ == "__main__":
    sys.exit(main())
