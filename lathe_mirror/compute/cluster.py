"""The Dask executor: a cluster at a scheduler address (tcp://HOST:PORT only).

Before dask.distributed's Client is made, the address must answer as a Dask scheduler:
the TCP connection within CONNECT_TIMEOUT_S, then the scheduler's handshake (the first
message a Dask server sends on every new connection, a msgpack dict naming its pickle
protocol) within REPLY_TIMEOUT_S. A port that accepts and stays silent (an HTTP server
waits for a request), one that sends other bytes, or one that closes is refused with one
line naming the address: the Client itself would wait on a silent peer long past its
timeout and read other bytes as a frame length (gigabytes allocated).

`shared` goes to the workers once per run, not once per stage: each of its parts (a
dataclass's fields, else the whole) is scattered (broadcast to every worker) only if no
part with the same pickled bytes was sent before (a run's stages share the mirror, the
surfaces and the pixel samples; a surface bank that gained noses is new bytes, sent
again); the last SENT_KEPT parts stay on the workers until the executor closes. Each
block of items is sent with the futures of the parts, so no block pickles them again.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import pickle
import socket
import struct
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from ..errors import InputError
from . import Background, Executor, Mapper, tick

#: Seconds to open the TCP connection to a scheduler.
CONNECT_TIMEOUT_S = 10.0
#: Seconds, from the connection, for the scheduler's first message (Dask's handshake).
REPLY_TIMEOUT_S = 10.0
#: Scattered parts kept on the workers for reuse (the oldest released beyond it).
SENT_KEPT = 16
#: The handshake is a few dozen bytes; a longer first frame is not a Dask scheduler.
_MAX_HANDSHAKE_BYTES = 1 << 16


@dataclass(frozen=True)
class Capacity:
    """What a cluster offers the trials: worker threads (each runs one block at a time)
    and the memory of its smallest worker (bytes; inf when the workers have no limit)."""

    threads: int
    worker_memory_bytes: float
    workers: int


class DaskExecutor(Executor):
    """A Dask distributed cluster at `address` (compute's module doc)."""

    kind = "dask"

    def __init__(self, address: str) -> None:
        self.address = address
        self._client = None
        self._capacity: Capacity | None = None
        self._closed = False
        self._sent: dict[str, Any] = {}  # digest of a part's pickle -> its future on the workers
        self.broadcasts = 0  # parts scattered, and their pickled bytes (the benchmark, the tests)
        self.broadcast_bytes = 0
        super().__init__(0)

    def client(self):
        if self._client is None:
            handshake(self.address)
            try:
                from dask.distributed import Client
            except ImportError as exc:  # pragma: no cover - dask[distributed] is a dependency
                raise InputError(f"--scheduler {self.address}: dask.distributed is not installed ({exc})") from None
            try:
                self._client = Client(self.address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
                info = self._client.scheduler_info()
            except Exception as exc:  # noqa: BLE001 - whatever the peer did, one line naming it
                raise InputError(f"--scheduler {self.address}: the Dask scheduler did not take the client "
                                 f"({type(exc).__name__}: {' '.join(str(exc).split())[:200]})") from None
            self._capacity = capacity_of(info)
            self.workers = self._capacity.threads
        return self._client

    @property
    def connected(self) -> bool:
        """Not closed (a new executor, not connected yet, counts as connected: it connects
        when first used)."""
        return not self._closed

    def capacity(self) -> Capacity:
        """The cluster's worker threads and memory (from the scheduler, at connection)."""
        self.client()
        assert self._capacity is not None
        return self._capacity

    @contextlib.contextmanager
    def bound(self, shared: Any) -> Iterator[Mapper]:
        client = self.client()
        mapper = DaskMapper(client, self._on_workers(shared))
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

    def _on_workers(self, shared: Any) -> tuple:
        """(rebuild, names, futures): shared's parts on every worker (module doc)."""
        if dataclasses.is_dataclass(shared) and not isinstance(shared, type):
            names = tuple(f.name for f in dataclasses.fields(shared))
            return type(shared), names, tuple(self._part(getattr(shared, n)) for n in names)
        return None, (), (self._part(shared),)

    def _part(self, obj: Any):
        """The future of obj on every worker: scattered now unless the same bytes were."""
        import cloudpickle  # Dask's own: it pickles what the workers get (closures too)

        try:
            data = cloudpickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
            digest = hashlib.blake2b(data, digest_size=20).hexdigest()
        except Exception:  # noqa: BLE001 - not picklable here: scatter says why, or sends it
            data, digest = b"", None
        future = self._sent.pop(digest, None) if digest else None
        if future is None:
            future = self._client.scatter(obj, broadcast=True, hash=False)
            self.broadcasts += 1
            self.broadcast_bytes += len(data)
        if digest:
            self._sent[digest] = future  # most recent last
            while len(self._sent) > SENT_KEPT:
                self._sent.pop(next(iter(self._sent)))
        return future

    def close(self) -> None:
        self._closed = True
        self._sent.clear()
        if self._client is not None:
            with contextlib.suppress(Exception):
                self._client.close()
            self._client = None

    def describe(self) -> str:
        return f"Dask at {self.address} ({self.workers} worker threads)"


class DaskMapper(Mapper):
    def __init__(self, client, shared_future) -> None:
        self.client, self.shared, self.futures = client, shared_future, []

    def map(self, fn, items, progress=None) -> list:
        items = list(items)
        rebuild, names, parts = self.shared
        n = len(items)
        self.futures = self.client.map(call, [fn] * n, [rebuild] * n, [names] * n, [parts] * n, items, pure=False)
        out = []
        for f, item in zip(self.futures, items):
            out.append(f.result())
            tick(progress, item)
        self.futures = []
        return out

    def cancel(self) -> None:
        if self.futures:
            with contextlib.suppress(Exception):
                self.client.cancel(self.futures)
        self.futures = []


def call(fn, rebuild, names, parts, item):
    """fn(shared, item) on a worker, shared rebuilt from its parts (the futures resolved)."""
    shared = rebuild(**dict(zip(names, parts))) if rebuild is not None else parts[0]
    return fn(shared, item)


def capacity_of(info: dict) -> Capacity:
    """Capacity from Client.scheduler_info(): threads summed, the least memory_limit
    (0, no limit, counts as unbounded)."""
    workers = list(info.get("workers", {}).values())
    threads = sum(int(w.get("nthreads", 1)) for w in workers)
    limits = [float(w.get("memory_limit") or 0.0) for w in workers]
    memory = min((m if m > 0 else float("inf") for m in limits), default=0.0)
    return Capacity(max(1, threads), memory, len(workers))


def handshake(address: str) -> None:
    """InputError naming the address unless a Dask scheduler answers there (module doc).
    The frame is Dask's TCP framing: a uint64 byte count, then a uint64 count of frames,
    their uint64 lengths and the frames; the first frame is the msgpack handshake."""
    host, _, port = address[len("tcp://"):].rpartition(":")
    try:
        sock = socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S)
    except OSError as exc:
        raise InputError(f"--scheduler {address}: cannot reach the Dask scheduler "
                         f"({' '.join(str(exc).split())[:200]})") from None
    try:
        deadline = time.monotonic() + REPLY_TIMEOUT_S
        head = _read(sock, 8, deadline, address)
        (size,) = struct.unpack("<Q", head)
        if not 16 <= size <= _MAX_HANDSHAKE_BYTES:
            raise _not_dask(address, head + _more(sock))
        body = _read(sock, size, deadline, address)
        (count,) = struct.unpack_from("<Q", body)
        if not 1 <= count <= 16 or size < 8 + 8 * count:
            raise _not_dask(address, head + body)
        lengths = struct.unpack_from(f"<{count}Q", body, 8)
        if 8 + 8 * count + sum(lengths) != size:
            raise _not_dask(address, head + body)
        start = 8 + 8 * count
        try:
            import msgpack

            info = msgpack.loads(body[start:start + lengths[0]])
        except Exception:  # noqa: BLE001 - any undecodable frame is "not Dask"
            info = None
        if not (isinstance(info, dict) and "pickle-protocol" in info):
            raise _not_dask(address, head + body)
    finally:
        sock.close()


def _read(sock: socket.socket, n: int, deadline: float, address: str) -> bytes:
    """n bytes before the deadline, or InputError (silent, closed)."""
    out = bytearray()
    while len(out) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise _silent(address)
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(out))
        except (TimeoutError, socket.timeout):
            raise _silent(address) from None
        except OSError as exc:
            raise InputError(f"--scheduler {address}: the connection failed before a Dask scheduler answered "
                             f"({exc.strerror or exc})") from None
        if not chunk:
            raise InputError(f"--scheduler {address}: the peer closed the connection without answering as a "
                             "Dask scheduler")
        out += chunk
    return bytes(out)


def _more(sock: socket.socket) -> bytes:
    """A few more bytes the peer has sent, if any (for the message)."""
    try:
        sock.settimeout(0.05)
        return sock.recv(8)
    except OSError:
        return b""


def _silent(address: str) -> InputError:
    return InputError(f"--scheduler {address}: no answer from a Dask scheduler within {REPLY_TIMEOUT_S:g} s "
                      "of connecting (something else listens there?)")


def _not_dask(address: str, first: bytes) -> InputError:
    return InputError(f"--scheduler {address}: the peer answered, but not as a Dask scheduler (first bytes "
                      f"{first[:16]!r})")
