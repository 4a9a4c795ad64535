"""One executor for the heavy trials: the Monte Carlo's, the allocation's confirmations, the
sensitivity runs and the optimiser's evaluations all go through `active().bound(shared)`.

    with compute.session(workers=4):                 # or scheduler="tcp://host:8786"
        with compute.active().bound(shared) as run:  # the workers hold `shared` once
            results = run.map(fn, items, progress=bar)  # fn(shared, item), in item order

Three kinds, one answer (the results come back in the order of the items, each computed
from its item alone, so the same inputs give the same bytes whichever runs them):

* serial (workers = 1, and inside a worker): in this process;
* processes (the default, workers = all cores): forked workers, each with its own pipe
  (no shared lock a killed worker could leave held), one task at a time each; `shared`
  is inherited by the fork, not pickled. Workers ignore SIGINT and SIGTERM: on a signal
  (or any error) the parent kills and joins them before the exception leaves `bound`,
  so Ctrl-C on the process group ends the command within a second with no orphan; a
  worker whose parent died reads EOF on its pipe and exits;
* dask: a Dask cluster at a scheduler address (`--scheduler tcp://HOST:PORT`, or
  `[compute] scheduler`): `shared` is scattered to every worker once, the items mapped.
  The workers need lathe_mirror importable.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from .errors import InputError

#: The largest --workers accepted (compute.workers' range; 0: all cores).
MAX_WORKERS = 1024
#: Seconds to reach a Dask scheduler before giving up.
CONNECT_TIMEOUT_S = 10.0
_ADDRESS = re.compile(r"(tcp|tls|ucx|ws|wss)://[^\s/]+:\d{1,5}|inproc://\S+")


def default_workers() -> int:
    """All the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def check_workers(workers: int, flag: str = "--workers") -> int:
    if isinstance(workers, bool) or not isinstance(workers, int) or not 0 <= workers <= MAX_WORKERS:
        raise InputError(f"{flag} {workers}: allowed 0 .. {MAX_WORKERS} (processes; 0: all cores, "
                         "1 runs in this process)")
    return workers


def check_scheduler(address: str, flag: str = "--scheduler") -> str:
    if not isinstance(address, str) or not _ADDRESS.fullmatch(address):
        raise InputError(f"{flag} {address!r}: a Dask scheduler address, e.g. tcp://HOST:8786")
    return address


class Mapper:
    """What `Executor.bound` yields: map(fn, items, progress=None) -> list, fn(shared, item)
    at module level (the workers import it by name)."""

    def map(self, fn: Callable[[Any, Any], Any], items: Sequence, progress=None) -> list:
        raise NotImplementedError


class Executor:
    """Serial: everything in this process."""

    kind = "serial"

    def __init__(self, workers: int = 1) -> None:
        self.workers = workers

    @contextlib.contextmanager
    def bound(self, shared: Any) -> Iterator[Mapper]:
        yield _SerialMapper(shared)

    @contextlib.contextmanager
    def background(self, fn: Callable[[Any], Any], shared: Any) -> Iterator["Background"]:
        """fn(shared) while the caller goes on: `.result()` waits for it (serial: runs it
        then). Leaving the block early (an error, a signal) abandons it."""
        yield Background(lambda: fn(shared))

    def close(self) -> None:
        pass

    def describe(self) -> str:
        return "1 process (serial)"


class Background:
    """A task started by Executor.background; result() waits for its value."""

    def __init__(self, wait: Callable[[], Any]) -> None:
        self._wait, self._done, self._value = wait, False, None

    def result(self) -> Any:
        if not self._done:
            self._value, self._done = self._wait(), True
        return self._value


class _SerialMapper(Mapper):
    def __init__(self, shared: Any) -> None:
        self.shared = shared

    def map(self, fn, items, progress=None) -> list:
        out = []
        for item in items:
            out.append(fn(self.shared, item))
            _tick(progress, item)
        return out


# --------------------------------------------------------------------------------------
# Local processes


class ProcessExecutor(Executor):
    """Forked worker processes (module doc)."""

    kind = "processes"

    @contextlib.contextmanager
    def bound(self, shared: Any) -> Iterator[Mapper]:
        pool = _ForkPool(self.workers, shared)
        try:
            yield pool
        except BaseException:
            pool.kill()
            raise
        else:
            pool.close()

    @contextlib.contextmanager
    def background(self, fn: Callable[[Any], Any], shared: Any) -> Iterator[Background]:
        """fn(shared) in a forked process of its own, which keeps this executor for its
        own trials (its pool's processes and ours share the cores)."""
        pool = _ForkPool(1, shared, nested=self.workers)
        try:
            conn = pool.conns[0]
            conn.send((0, _call_shared, fn))

            def wait():
                try:
                    _, ok, value = conn.recv()
                except EOFError:
                    raise RuntimeError("a worker process died (out of memory?)") from None
                if not ok:
                    raise value
                return value

            yield Background(wait)
        except BaseException:
            pool.kill()
            raise
        else:
            pool.close()

    def describe(self) -> str:
        return f"{self.workers} processes"


def _call_shared(shared, fn):
    return fn(shared)


class _ForkPool(Mapper):
    def __init__(self, workers: int, shared: Any, nested: int = 1) -> None:
        import multiprocessing

        ctx = multiprocessing.get_context("fork")
        self.procs, self.conns = [], []
        # The terminal's signals wait while we fork (a worker ignores them before it
        # unblocks them; here they arrive, as KeyboardInterrupt / Terminated, after).
        mask = {signal.SIGINT, signal.SIGTERM}
        old = signal.pthread_sigmask(signal.SIG_BLOCK, mask)
        try:
            try:
                for _ in range(workers):
                    parent, child = ctx.Pipe(duplex=True)
                    p = ctx.Process(target=_worker_main, args=(child, parent, shared, nested),
                                    daemon=nested == 1)
                    p.start()
                    child.close()
                    self.procs.append(p)
                    self.conns.append(parent)
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, old)  # a waiting signal raises here
        except BaseException:
            self.kill()
            raise

    def map(self, fn, items, progress=None) -> list:
        from multiprocessing.connection import wait

        items = list(items)
        results: list = [None] * len(items)
        todo = list(range(len(items)))[::-1]
        busy: dict = {}
        idle = list(self.conns)
        while todo or busy:
            while todo and idle:
                conn = idle.pop()
                i = todo.pop()
                conn.send((i, fn, items[i]))
                busy[conn] = i
            for conn in wait(list(busy)):
                try:
                    i, ok, value = conn.recv()
                except EOFError:
                    raise RuntimeError("a worker process died (out of memory?)") from None
                del busy[conn]
                idle.append(conn)
                if not ok:
                    raise value
                results[i] = value
                _tick(progress, items[i])
        return results

    def close(self) -> None:
        for conn in self.conns:
            with contextlib.suppress(OSError):
                conn.send(None)
        for p in self.procs:
            p.join(timeout=5)
            if p.is_alive():
                p.kill()
                p.join()
        self._close_conns()

    def kill(self) -> None:
        """SIGKILL every worker (they ignore SIGINT and SIGTERM) and reap them."""
        for p in self.procs:
            with contextlib.suppress(Exception):
                p.kill()
        for p in self.procs:
            with contextlib.suppress(Exception):
                p.join(timeout=1)
        self._close_conns()

    def _close_conns(self) -> None:
        for conn in self.conns:
            with contextlib.suppress(OSError):
                conn.close()
        self.conns = []


def _worker_main(conn, parent_end, shared, nested: int = 1) -> None:
    """A worker: ignore the terminal's signals (the parent ends us), die with the parent
    (Linux: PR_SET_PDEATHSIG), then run tasks until told to stop or the parent goes away.
    nested: the workers of its own trials (1: in the worker itself)."""
    global _ACTIVE
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    _die_with_parent()
    parent_end.close()
    _ACTIVE = ProcessExecutor(nested) if nested > 1 else Executor(1)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            break
        if msg is None:
            break
        i, fn, item = msg
        try:
            reply = (i, True, fn(shared, item))
        except BaseException as exc:  # noqa: BLE001 - handed to the parent, which raises it
            reply = (i, False, exc)
        try:
            conn.send(reply)
        except (EOFError, OSError, BrokenPipeError):
            break
        except Exception as exc:  # the exception (or result) does not pickle
            with contextlib.suppress(Exception):
                conn.send((i, False, RuntimeError(f"{type(exc).__name__}: {exc}")))
    os._exit(0)  # no atexit handlers or buffers of the parent's inherited state


def _die_with_parent() -> None:
    """SIGKILL this process when its parent dies (Linux prctl; elsewhere the pipe's EOF
    ends an idle worker)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


# --------------------------------------------------------------------------------------
# Dask


class DaskExecutor(Executor):
    """A Dask distributed cluster at `address` (module doc)."""

    kind = "dask"

    def __init__(self, address: str) -> None:
        self.address = address
        self._client = None
        super().__init__(0)

    def client(self):
        if self._client is None:
            try:
                _reachable(self.address)
            except OSError as exc:
                raise InputError(f"--scheduler {self.address}: cannot reach the Dask scheduler "
                                 f"({' '.join(str(exc).split())[:200]})") from None
            try:
                from dask.distributed import Client
            except ImportError as exc:  # pragma: no cover - dask[distributed] is a dependency
                raise InputError(f"--scheduler {self.address}: dask.distributed is not installed ({exc})") from None
            try:
                self._client = Client(self.address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
            except (OSError, TimeoutError) as exc:
                raise InputError(f"--scheduler {self.address}: cannot reach the Dask scheduler "
                                 f"({' '.join(str(exc).split())[:200]})") from None
            self.workers = max(1, sum(w.get("nthreads", 1) for w in
                                      self._client.scheduler_info().get("workers", {}).values()))
        return self._client

    @contextlib.contextmanager
    def bound(self, shared: Any) -> Iterator[Mapper]:
        client = self.client()
        mapper = _DaskMapper(client, client.scatter(shared, broadcast=True, hash=False))
        try:
            yield mapper
        finally:
            mapper.cancel()

    @contextlib.contextmanager
    def background(self, fn: Callable[[Any], Any], shared: Any) -> Iterator[Background]:
        future = self.client().submit(fn, shared, pure=False)
        try:
            yield Background(future.result)
        finally:
            with contextlib.suppress(Exception):
                future.cancel()

    def close(self) -> None:
        if self._client is not None:
            with contextlib.suppress(Exception):
                self._client.close()
            self._client = None

    def describe(self) -> str:
        return f"Dask at {self.address} ({self.workers} worker threads)"


class _DaskMapper(Mapper):
    def __init__(self, client, shared_future) -> None:
        self.client, self.shared, self.futures = client, shared_future, []

    def map(self, fn, items, progress=None) -> list:
        items = list(items)
        self.futures = self.client.map(_call, [fn] * len(items), [self.shared] * len(items), items, pure=False)
        out = []
        for f, item in zip(self.futures, items):
            out.append(f.result())
            _tick(progress, item)
        self.futures = []
        return out

    def cancel(self) -> None:
        if self.futures:
            with contextlib.suppress(Exception):
                self.client.cancel(self.futures)
        self.futures = []


def _reachable(address: str) -> None:
    """A TCP scheduler's port answers (OSError at once if refused)."""
    import socket

    if address.startswith("tcp://"):
        host, _, port = address[len("tcp://"):].rpartition(":")
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S).close()


def _call(fn, shared, item):
    return fn(shared, item)


# --------------------------------------------------------------------------------------
# The active executor


_ACTIVE: Executor = Executor(1)


def active() -> Executor:
    """The executor of the running command (serial unless a session says otherwise)."""
    return _ACTIVE


def make(workers: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor for --workers / --scheduler: Dask when a scheduler is given, else
    `workers` local processes (default: all cores), serial for 1."""
    if scheduler:
        ex = DaskExecutor(check_scheduler(scheduler))
        ex.client()  # connect now: an unreachable scheduler is bad input, before any work
        return ex
    n = check_workers(workers) if workers else default_workers()
    return Executor(1) if n == 1 else ProcessExecutor(n)


def activate(workers: int | None = None, scheduler: str | None = None) -> Executor:
    """Make the executor active until `shutdown` (the command line's: cli.main shuts it
    down when the command ends, however it ends)."""
    global _ACTIVE
    _ACTIVE.close()
    _ACTIVE = make(workers, scheduler)
    return _ACTIVE


def shutdown() -> None:
    """Close the active executor; serial again."""
    global _ACTIVE
    ex, _ACTIVE = _ACTIVE, Executor(1)
    ex.close()


@contextlib.contextmanager
def session(workers: int | None = None, scheduler: str | None = None) -> Iterator[Executor]:
    """Make the executor active for the block (then close it and restore the previous)."""
    global _ACTIVE
    ex = make(workers, scheduler)
    previous, _ACTIVE = _ACTIVE, ex
    try:
        yield ex
    finally:
        _ACTIVE = previous
        ex.close()


def _tick(progress, item) -> None:
    if progress is not None:
        n = len(item) if hasattr(item, "__len__") and not isinstance(item, (str, bytes)) else 1
        progress.update(n)
