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
  is inherited by the fork, not pickled. Workers ignore SIGINT, SIGTERM, SIGHUP and
  SIGQUIT: on a signal (or any error) the parent kills and reaps them (and a background
  task's own workers) before the exception leaves `bound`, so Ctrl-C on the process
  group ends the command within a second with no orphan and no zombie; a worker whose
  parent died is killed with it (PR_SET_PDEATHSIG) or reads EOF on its pipe and exits;
* dask: a Dask cluster at a scheduler address (`--scheduler tcp://HOST:PORT`, or
  `[compute] scheduler`; compute.cluster): the scheduler must answer within stated
  timeouts, `shared` is scattered to every worker once, the items mapped. The workers
  need lathe_mirror importable.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..errors import ENDING_SIGNALS, InputError

#: The signals that end a command (the command line's handlers catch them): a worker
#: ignores them, its parent ends it.
_ENDING = tuple(getattr(signal, name) for name in ENDING_SIGNALS)
#: The largest --workers accepted (compute.workers' range; 0: all cores).
MAX_WORKERS = 1024
#: A scheduler's address: tcp:// only (Dask's tls://, ucx://, ws://, inproc:// are refused:
#: there are no options for their certificates or devices, and inproc:// is not reachable
#: from a command line), a host name,
#: an IPv4 address or a bracketed IPv6 one, and a port 1 .. 65535.
_ADDRESS = re.compile(r"tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9._-]*):([0-9]{1,5})")


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
    """The address, or InputError at parsing: tcp://HOST:PORT only (see _ADDRESS)."""
    m = _ADDRESS.fullmatch(address) if isinstance(address, str) else None
    if m is None or not 1 <= int(m.group(2)) <= 65535:
        scheme = address.split("://", 1)[0] + "://" if isinstance(address, str) and "://" in address else ""
        why = (f"protocol {scheme} is not supported" if scheme and scheme != "tcp://" else
               "port 1 .. 65535" if m is not None else "not a scheduler address")
        raise InputError(f"{flag} {address!r}: {why}; allowed a Dask scheduler's tcp://HOST:PORT, "
                         "e.g. tcp://10.0.0.5:8786")
    return address


#: Blocks a map's items are split in, per worker thread (compute.blocks): at least the
#: first, at most the second: enough that the workers finish within a block of each other,
#: few enough that a block's overhead stays small (evaluating the paper default's trials
#: in 10 blocks instead of 1 cost 10 % more CPU: each block's set-up and fresh arrays).
BLOCKS_PER_WORKER = (2, 4)


def blocks(n: int, unit: int, workers: int) -> list[slice]:
    """range(n) split in consecutive slices of whole `unit`s (the last may end short), as
    even as whole units allow, so that every worker is busy to the end: the count of
    blocks (BLOCKS_PER_WORKER per worker, all the units if fewer) the one whose rounds
    (ceil(blocks / workers) of ceil(units / blocks) units) end first. 2,000 trials in
    batches of 100 on 2 workers: 4 blocks of 500 (not 400, 400, 400 | 400, 400)."""
    units = -(-n // max(unit, 1))
    w = max(workers, 1)
    lo, hi = BLOCKS_PER_WORKER[0] * w, BLOCKS_PER_WORKER[1] * w
    if units <= lo:
        count = max(units, 1)
    else:
        count = min(range(lo, min(units, hi) + 1), key=lambda c: (-(-c // w)) * (-(-units // c)))
    edges = [min(n, unit * (units * k // count)) for k in range(count + 1)]
    return [slice(a, b) for a, b in zip(edges, edges[1:]) if b > a]


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
            tick(progress, item)
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
        _adopt_orphans()  # its own pool's workers are reaped here if it is killed
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
        self.procs, self.conns, self.nested = [], [], nested
        # The terminal's signals wait while we fork (a worker ignores them before it
        # unblocks them; here they arrive, as KeyboardInterrupt / Terminated, after).
        mask = set(_ENDING)
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
                tick(progress, items[i])
        return results

    def close(self) -> None:
        for conn in self.conns:
            with contextlib.suppress(OSError):
                conn.send(None)
        for p in self.procs:
            p.join(timeout=5)
            if p.is_alive():
                p.kill()
                p.join(timeout=_REAP_S)
        self._close_conns()

    def kill(self) -> None:
        """SIGKILL every worker (they ignore the ending signals) and the workers of their
        own pools (a background task's), and reap them all: none is left to init."""
        grandchildren: list[int] = []  # every descendant, a generation after the other
        if self.nested > 1:  # each generation stopped first: none forks after its listing
            level = {p.pid for p in self.procs if p.pid}
            while level:
                _stop(level)
                level = set(_children_of(level)) - set(grandchildren)
                grandchildren += sorted(level)
        for p in self.procs:
            with contextlib.suppress(Exception):
                p.kill()
        for pid in grandchildren:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        for p in self.procs:
            with contextlib.suppress(Exception):
                p.join(timeout=_REAP_S)
        for pid in grandchildren:  # ours now (_adopt_orphans), their parents reaped before them
            with contextlib.suppress(ChildProcessError, OSError):
                os.waitpid(pid, 0)
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
    for sig in _ENDING:
        signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, set(_ENDING))
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


#: Seconds to wait for a SIGKILLed worker's exit (it cannot refuse; only a process stuck in
#: the kernel takes longer).
_REAP_S = 10.0


def _adopt_orphans() -> None:
    """Make this process the reaper of its orphaned descendants (Linux prctl
    PR_SET_CHILD_SUBREAPER): a background task's own workers, killed with it, become
    this process's children, which it waits for, instead of init's zombies after it exits."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


def _stop(pids: set[int], timeout: float = 2.0) -> None:
    """SIGSTOP the processes and wait (at most `timeout` s) until each is stopped or gone:
    a stopped process forks no more, so a listing of its children after is complete."""
    import time

    for pid in pids:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGSTOP)
    deadline = time.monotonic() + timeout
    waiting = set(pids)
    while waiting and time.monotonic() < deadline:
        for pid in list(waiting):
            try:
                with open(f"/proc/{pid}/stat", "rb") as f:
                    stat = f.read()
            except OSError:  # gone (or not Linux: nothing to wait for)
                waiting.discard(pid)
                continue
            if stat[stat.rindex(b")") + 2:][:1] in (b"T", b"t", b"Z", b"X"):
                waiting.discard(pid)
        if waiting:
            time.sleep(0.001)


def _children_of(parents: set[int]) -> list[int]:
    """The pids whose parent is one of `parents` (from /proc/*/stat; [] elsewhere)."""
    out = []
    try:
        entries = os.listdir("/proc")
    except OSError:  # pragma: no cover - not Linux
        return out
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rindex(b")") + 2:].split()
        if int(fields[1]) in parents:
            out.append(int(entry))
    return out


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
# The active executor


_ACTIVE: Executor = Executor(1)


def active() -> Executor:
    """The executor of the running command (serial unless a session says otherwise)."""
    return _ACTIVE


def make(workers: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor for --workers / --scheduler: Dask when a scheduler is given, else
    `workers` local processes (default: all cores), serial for 1."""
    if scheduler:
        ex = _cluster(scheduler)
        ex.client()  # connect now: an unreachable scheduler is bad input, before any work
        return ex
    n = check_workers(workers) if workers else default_workers()
    return Executor(1) if n == 1 else ProcessExecutor(n)


#: The Dask executors connected in this process, by address (the cost check's connection
#: is the command's).
_CLUSTERS: dict = {}


def cluster_capacity(address: str):
    """The Dask cluster's compute.cluster.Capacity at address (threads, least worker
    memory), from its scheduler; the connection is the one `make` then uses."""
    return _cluster(address).capacity()


def _cluster(address: str):
    from .cluster import DaskExecutor  # lazy: dask.distributed only for a --scheduler run

    ex = _CLUSTERS.get(address)
    if ex is None or not ex.connected:
        ex = _CLUSTERS[address] = DaskExecutor(check_scheduler(address))
    return ex


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


def tick(progress, item) -> None:
    """Advance a progress bar by an item's trials (its length) or by one."""
    if progress is not None:
        n = len(item) if hasattr(item, "__len__") and not isinstance(item, (str, bytes)) else 1
        progress.update(n)
