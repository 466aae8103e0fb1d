"""``stlc sweep`` refuses before it starts: a user's ``plans/<i>.csv`` in the output folder
(never overwritten), instance counts out of range (no allocation first) and a TCP server
that is not a Dask scheduler (silent, or answering garbage) — diagnostics, exit 1."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time

import pytest
from test_set import SOURCE

from stlc.sweeping.handshake import probe


def stlc(*args, **kw):
    return subprocess.run([sys.executable, "-m", "stlc", *args], capture_output=True,
                          text=True, timeout=120, **kw)


@pytest.fixture
def spec(tmp_path):
    f = tmp_path / "m.stl"
    f.write_text(SOURCE)
    return f


def test_a_users_plan_file_is_never_overwritten(tmp_path, spec):
    out = tmp_path / "out"
    (out / "plans").mkdir(parents=True)
    mine = out / "plans" / "7.csv"
    mine.write_text("my own data\n")
    r = stlc("sweep", str(spec), "--mission", "m", "--vary", "T=2.6 s:3 s:8", "-o", str(out),
             "--workers", "1", "-q")
    assert r.returncode == 1 and "error[STL605]" in r.stderr, r.stderr
    assert "plans/7.csv" in r.stderr and "Traceback" not in r.stderr
    assert mine.read_text() == "my own data\n"
    assert sorted(p.name for p in out.iterdir()) == ["plans"]  # nothing else written


@pytest.mark.parametrize("args", [["--random", "0"], ["--random", "-1"],
                                  ["--random", "1000000000"],
                                  ["--vary", "op.pos.y=0 m:1 m:50", "--vary",
                                   "op.pos.z=0 m:1 m:50"]])
def test_instance_counts_are_checked_before_allocation(tmp_path, spec, args):
    t0 = time.monotonic()
    r = stlc("sweep", str(spec), "--mission", "m", "--vary", "op.pos.x=0 m:1 m:50", *args,
             "-o", str(tmp_path / "o"), "-q")
    assert r.returncode == 1 and "error[STL104]" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and time.monotonic() - t0 < 60
    assert not (tmp_path / "o").exists()


class _Server:
    """A TCP server that accepts and then says nothing, or ``reply``."""

    def __init__(self, reply: bytes | None):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(4)
        self.reply, self.conns = reply, []
        threading.Thread(target=self._serve, daemon=True).start()

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"

    def _serve(self):
        while True:
            try:
                c, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(c)
            if self.reply is not None:
                c.sendall(self.reply)

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.mark.parametrize("reply", [None, b"\xff" * 64, b"HTTP/1.1 200 OK\r\n\r\nhello\n"],
                         ids=["silent", "garbage", "http"])
def test_a_server_that_is_not_dask_is_a_diagnostic(tmp_path, spec, reply):
    srv = _Server(reply)
    try:
        assert probe(srv.address, timeout=1.0) is not None
        t0 = time.monotonic()
        r = stlc("sweep", str(spec), "--mission", "m", "--vary", "T=2.6 s:3 s:2",
                 "--scheduler", srv.address, "-o", str(tmp_path / "o"), "-q")
        assert r.returncode == 1 and "error[STL607]" in r.stderr, r.stderr
        assert "not a Dask scheduler" in r.stderr and "Traceback" not in r.stderr
        assert time.monotonic() - t0 < 60
    finally:
        srv.close()


def test_nothing_listening_is_a_diagnostic():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert probe(f"tcp://127.0.0.1:{port}", timeout=1.0) is not None


def test_a_dask_scheduler_passes_the_probe():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as c:
        assert probe(c.scheduler_address, timeout=5.0) is None
