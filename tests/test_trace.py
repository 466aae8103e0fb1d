"""Trace CSV reader: good files, every malformed case with its code and span, random bytes."""

from __future__ import annotations

import os
import tempfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlc.analysis.trace import check_signals, read_trace
from stlc.diagnostics import Span, StlcError


def write(tmp_path, content: str | bytes, name: str = "trace.csv") -> str:
    p = tmp_path / name
    if isinstance(content, str):
        content = content.encode("utf-8")
    p.write_bytes(content)
    return str(p)


def error(path):
    with pytest.raises(StlcError) as info:
        read_trace(path)
    return info.value.diagnostics


def test_good_file(tmp_path):
    path = write(tmp_path, "t,x,uav1.pos.z\n0,1.5,2\n0.1,-2,3e-1\n0.2, .5 ,+4\n\n")
    tr = read_trace(path)
    assert tr.dt == 0.1 and tr.n == 3 and tr.path == path
    np.testing.assert_array_equal(tr.times, [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(tr.channels["x"], [1.5, -2.0, 0.5])
    np.testing.assert_array_equal(tr.channels["uav1.pos.z"], [2.0, 0.3, 4.0])
    assert list(tr.channels) == ["x", "uav1.pos.z"]


def test_crlf_bom_quotes_and_one_row(tmp_path):
    tr = read_trace(write(tmp_path, '\ufefft,"x"\r\n5,1\r\n'))
    assert tr.n == 1 and tr.dt == 1.0 and tr.times[0] == 5.0
    np.testing.assert_array_equal(tr.channels["x"], [1.0])


def test_dt_from_rounded_times(tmp_path):
    rows = "\n".join(f"{k / 3:.3f},{k}" for k in range(50))
    tr = read_trace(write(tmp_path, "t,x\n" + rows))
    assert tr.dt == pytest.approx(1 / 3, rel=1e-4)
    tr = read_trace(write(tmp_path, "t,x\n" + "\n".join(f"{k * 0.1},{k}" for k in range(100))))
    assert tr.dt == 0.1


@pytest.mark.parametrize("content, code, line, col, end_col", [
    ("", "STL602", 1, 1, 1),
    ("\n  \n", "STL602", 1, 1, 1),
    ("time,x\n0,1\n", "STL602", 1, 1, 5),
    ("t,x\n", "STL602", 1, 4, 5),
    ("t,x,x\n0,1,2\n", "STL602", 1, 5, 6),
    ("t,x,\n0,1,2\n", "STL602", 1, 5, 6),
    ("t,x\n0,1\n0.1,2,3\n", "STL602", 3, 1, 8),
    ("t,x\n0,1\n0.1\n", "STL602", 3, 1, 4),
    ("t,x\n0,1\n0.1, abc\n", "STL602", 3, 6, 9),
    ("t,x\n0,1\n0.1,nan\n", "STL602", 3, 5, 8),
    ("t,x\n0,1\n0.1,\n", "STL602", 3, 5, 6),
    ("t,x\n0,1\n0.1,1_000\n", "STL602", 3, 5, 10),
    ("t,x\n0,1\n0.1,1e999\n", "STL602", 3, 5, 10),
    ("t,x\n0,1\ninf,2\n", "STL602", 3, 1, 4),
    ("t,x\n0,1\n0.2,1\n0.1,1\n", "STL604", 4, 1, 4),
    ("t,x\n0,1\n0,1\n", "STL604", 3, 1, 2),
    ("t,x\n0,1\n0.1,1\n0.2,1\n0.4,1\n0.5,1\n", "STL604", 5, 1, 4),
    ("t,x\n0,1\n0.1,1\n0.2,1\n 0.35 ,1\n", "STL604", 5, 2, 6),
])
def test_malformed(tmp_path, content, code, line, col, end_col):
    path = write(tmp_path, content)
    (d,) = error(path)
    assert d.code == code and d.help
    assert d.span == Span(path, line, col, line, end_col)


def test_collects_every_bad_value(tmp_path):
    diags = error(write(tmp_path, "t,x,y\n0,a,1\n1,2,b\n2,3\n"))
    assert [(d.code, d.span.line) for d in diags] == [("STL602", 2), ("STL602", 3),
                                                       ("STL602", 4)]


def test_unreadable(tmp_path):
    (d,) = error(str(tmp_path / "missing.csv"))
    assert d.code == "STL601" and "no such file" in d.message
    (d,) = error(str(tmp_path))
    assert d.code == "STL601" and "directory" in d.message
    (d,) = error(write(tmp_path, b"t,x\n0,\xff\xfe\n"))
    assert d.code == "STL601" and (d.span.line, d.span.col) == (2, 3)
    (d,) = error(write(tmp_path, b"t,x\n0,1\0\n"))
    assert d.code == "STL601" and "binary" in d.message


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.binary(max_size=200),
                 st.text(alphabet="t,x y0123456789.-+e\n\r\"nai_", max_size=120).map(
                     lambda s: s.encode("utf-8")),
                 st.text(max_size=60).map(lambda s: ("t,x\n0,1\n" + s).encode("utf-8",
                                                                              "surrogatepass"))))
def test_random_bytes_only_raise_stlc_error(data):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "t.csv")
        with open(path, "wb") as fh:
            fh.write(data)
        try:
            tr = read_trace(path)
        except StlcError as e:
            assert e.diagnostics and all(x.code.startswith("STL60") for x in e.diagnostics)
        else:
            assert tr.dt > 0 and tr.n >= 1
            assert all(len(v) == tr.n for v in tr.channels.values())


def test_check_signals(tmp_path):
    tr = read_trace(write(tmp_path, "t,uav1.pos.x,uav1.pos.y\n0,1,2\n"))
    check_signals(tr, {"uav1.pos.x"})
    with pytest.raises(StlcError) as info:
        check_signals(tr, {"uav1.pox.x", "uav1.pos.x", "speed"})
    d1, d2 = sorted(info.value.diagnostics, key=lambda d: d.message)
    assert d1.code == d2.code == "STL603"
    assert "speed" in d1.message and "uav1.pox.x" in d2.message
    assert d2.help == "did you mean `uav1.pos.x`?"
    assert d2.span == Span(tr.path, 1, 1, 1, 24)
    assert "uav1.pos.x, uav1.pos.y" in d1.notes[0]
    spec = Span("m.stl", 3, 4, 3, 9)
    with pytest.raises(StlcError) as info:
        check_signals(tr, {"z"}, lambda name: spec)
    assert info.value.diagnostics[0].span == spec
