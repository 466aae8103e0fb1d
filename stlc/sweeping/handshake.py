"""Before ``stlc sweep --scheduler ADDRESS`` hands the address to Dask: is a Dask scheduler
listening there?  And the budget of a sweep's instance count, checked before anything is
allocated.

A Dask listener speaks first: on accept it writes its handshake, one framed message (an
8-byte little-endian length, then the frames: a count, their lengths, msgpack).  ``probe``
connects with a timeout, reads that message within ``TIMEOUT_S`` and at most
``MAX_HANDSHAKE`` bytes, and decodes it with Dask's own framing.  A silent server (it
never writes), a garbage reply (an impossible length — Dask itself would try to allocate
it) or a closed connection are reported as STL607 with the reason, instead of a hang or an
internal error.  Other schemes than ``tcp://`` (``tls://``, ``ucx://``, ``inproc://``) are
left to Dask.
"""

from __future__ import annotations

import socket
import struct
import time

from stlc.diagnostics import Diagnostic, Span, StlcError

TIMEOUT_S = 5.0  #: connect + the scheduler's handshake
MAX_HANDSHAKE = 1 << 20  #: a handshake is a few hundred bytes


def _host_port(address: str) -> tuple[str, int] | None:
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    if scheme != "tcp":
        return None
    host, _, port = rest.rstrip("/").rpartition(":")
    host = host.strip("[]") or "127.0.0.1"
    try:
        return host, int(port)
    except ValueError:
        return host, 8786  # Dask's default scheduler port


def _read(sock: socket.socket, n: int, until: float) -> bytes:
    buf = bytearray()
    while len(buf) < n:
        left = until - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        chunk = sock.recv(min(n - len(buf), 65536))
        if not chunk:
            raise ConnectionError("the server closed the connection")
        buf += chunk
    return bytes(buf)


def probe(address: str, timeout: float = TIMEOUT_S) -> str | None:
    """Why ``address`` is not a Dask scheduler (None: it answered a Dask handshake, or the
    scheme is not plain TCP)."""
    hp = _host_port(address)
    if hp is None:
        return None
    until = time.monotonic() + timeout
    try:
        with socket.create_connection(hp, timeout=timeout) as sock:
            (n,) = struct.unpack("<Q", _read(sock, 8, until))
            if not 8 <= n <= MAX_HANDSHAKE:
                return (f"it answered with something that is not a Dask message (a length "
                        f"of {n} bytes)")
            body = _read(sock, n, until)
    except TimeoutError:
        return f"no Dask handshake within {timeout:g} s (the server is silent)"
    except (OSError, ConnectionError) as e:
        return getattr(e, "strerror", None) or str(e) or type(e).__name__
    try:
        from distributed.protocol.core import loads
        from distributed.protocol.utils import unpack_frames

        msg = loads(unpack_frames(body))
    except Exception:  # noqa: BLE001 - any decoding failure: not a Dask peer
        return "it answered with something that is not a Dask handshake"
    if not isinstance(msg, dict):
        return "it answered with something that is not a Dask handshake"
    return None


def check_scheduler(address: str, path: str) -> None:
    """STL607 unless ``probe`` finds a Dask scheduler at ``address``."""
    why = probe(address)
    if why is not None:
        raise StlcError([Diagnostic(
            "STL607", f"`{address}` is not a Dask scheduler: {why}", Span(path, 1, 1, 1, 2),
            "start one with `dask scheduler` and `dask worker ADDRESS`, or drop --scheduler "
            "for a local cluster")])


def check_count(path: str, sizes: list[int], random: int | None, limit: int) -> int:
    """The number of instances of a sweep (``sizes``: each axis' N; ``random``: the
    ``--random`` count), or STL104 when it is not in 1..``limit`` — before any instance is
    allocated."""
    where = Span(path, 1, 1, 1, 2)
    if random is not None:
        if not 1 <= random <= limit:
            raise StlcError([Diagnostic(
                "STL104", f"--random {random}: the number of instances must be in "
                f"1..{limit}", where, "e.g. --random 100")])
        return random
    total = 1
    for n in sizes:
        total *= int(n)
    if not 1 <= total <= limit:
        raise StlcError([Diagnostic(
            "STL104", f"the grid has {total:,} instances (" + " × ".join(map(str, sizes))
            + f"); the limit is {limit:,}", where,
            "use fewer points per --vary axis, or --random N to sample the same box")])
    return total
