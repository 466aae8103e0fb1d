"""Functions compiled to C (``stlc.solvers.codegen``): the same values as CasADi's own, one
library per set of functions in the cache directory, and CasADi's own functions whenever
nothing can be compiled."""

from __future__ import annotations

import os
import time

import casadi as ca
import numpy as np
import pytest

from stlc import settings
from stlc.solvers import codegen


def _functions():
    x, u, mu = ca.SX.sym("x", 3), ca.SX.sym("u", 2), ca.SX.sym("mu", 3)
    f = ca.vertcat(x[0] + 0.1 * ca.sin(x[1]) * u[0], x[1] * ca.exp(-u[1]), x[2] ** 2 + u[0])
    z = ca.vertcat(x, u)
    hess = ca.triu(ca.hessian(ca.dot(mu, f), z)[0])
    return [ca.Function("h", [x, u, mu], [hess]), ca.Function("j", [x, u], [ca.jacobian(f, z)])]


@pytest.fixture
def cache(tmp_path):
    with settings.override(cache_dir=str(tmp_path / "cache")):
        yield tmp_path / "cache"


def _values(fns, rng):
    X, U, M = rng.normal(size=(3, 20)), rng.normal(size=(2, 20)), rng.normal(size=(3, 20))
    return (np.asarray(fns[0].map(20)(X, U, M)), np.asarray(fns[1].map(20)(X, U)))


def test_compiled_functions_give_casadis_values(cache):
    if codegen.compiler() is None:  # this machine has no C compiler: CasADi's own, said so
        out = codegen.compiled(_functions(), "t", wait=True)
        assert codegen.last_status()["status"] == "no compiler"
        assert all(f.class_name() != "External" for f in out)
        return
    fns = _functions()
    out = codegen.compiled(fns, "t", wait=True)
    assert codegen.last_status()["status"] == "compiled"
    assert all(f.is_a("External") for f in out)
    libs = [p for p in os.listdir(cache) if p.endswith(".so")]
    assert len(libs) == 1 and not [p for p in os.listdir(cache) if p.startswith(".build-")]
    rng = np.random.default_rng(0)
    want, got = _values(fns, rng), _values(out, np.random.default_rng(0))
    for a, b in zip(want, got):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)


def test_a_library_is_compiled_once_and_loaded_after(cache):
    if codegen.compiler() is None:  # nothing compiled, nothing written
        codegen.compiled(_functions(), "once")
        assert codegen.last_status()["status"] == "no compiler" and not cache.exists()
        return
    codegen.compiled(_functions(), "once", wait=True)
    first = sorted(os.listdir(cache))
    codegen._LOADED.clear()  # a new process: the library is on disk
    codegen.compiled(_functions(), "once", wait=True)
    assert codegen.last_status()["status"] == "loaded"
    assert sorted(os.listdir(cache)) == first


def test_without_compiling_the_functions_are_casadis_own(cache):
    fns = _functions()
    with settings.override(compile="0"):
        out = codegen.compiled(fns, "off")
    assert out is fns and codegen.last_status()["status"] == "off"
    assert not cache.exists()


def test_a_compiler_that_fails_leaves_casadis_functions(cache, tmp_path):
    bad = tmp_path / "cc"
    bad.write_text("#!/bin/sh\necho 'no such compiler' >&2\nexit 1\n")
    bad.chmod(0o755)
    fns = _functions()
    with settings.override(c_compiler=str(bad)):
        out = codegen.compiled(fns, "bad", wait=True)
    st = codegen.last_status()
    assert out is fns and st["status"] == "failed" and "exited 1" in st["why"]
    assert not [p for p in os.listdir(cache) if p.endswith(".so")]


def test_an_unwritable_cache_leaves_casadis_functions(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        if os.access(ro, os.W_OK):  # (root writes anywhere: a file where the folder would be)
            blocker = tmp_path / "file"
            blocker.write_text("")
            where = str(blocker / "cache")
        else:
            where = str(ro / "cache")
        fns = _functions()
        with settings.override(cache_dir=where):
            out = codegen.compiled(fns, "ro", wait=True)
        assert out is fns
        assert codegen.last_status()["status"] == (
            "failed" if codegen.compiler() is not None else "no compiler")
    finally:
        ro.chmod(0o700)


def test_no_compiler_on_the_path_leaves_casadis_functions(cache, monkeypatch):
    monkeypatch.setenv("PATH", "")
    fns = _functions()
    with settings.override(c_compiler=""):
        assert codegen.compiler() is None
        out = codegen.compiled(fns, "none")
    assert out is fns and codegen.last_status()["status"] == "no compiler"
    assert not cache.exists()


def test_a_run_without_the_library_compiles_it_in_the_background(cache):
    fns = _functions()
    out = codegen.compiled(fns, "bg")
    if codegen.compiler() is None:
        assert out is fns and codegen.last_status()["status"] == "no compiler"
        return
    assert out is fns and codegen.last_status()["status"] == "compiling"
    codegen.start_pending()  # (as the run ends)
    again = codegen.compiled(fns, "bg")  # under way (or just done): not started twice
    assert (again is fns) == (codegen.last_status()["status"] == "compiling")
    assert len([d for d in os.listdir(cache) if d.startswith(".build-")]) <= 1
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and [d for d in os.listdir(cache)
                                           if d.startswith(".build-")]:
        time.sleep(0.1)
    assert [p for p in os.listdir(cache) if p.endswith(".so")], "the compile did not finish"
    out = codegen.compiled(fns, "bg")
    assert codegen.last_status()["status"] == "loaded" and all(f.is_a("External") for f in out)
    for a, b in zip(_values(fns, np.random.default_rng(1)), _values(out, np.random.default_rng(1))):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
