"""The output directory of ``stlc compile`` / ``simulate`` / ``risk``: what stlc may write
there, and how.

Contract (README, "Output directory"):

* stlc writes only the files of its output set into DIR (``OWNED``: solution.json,
  trajectory.csv, report.html, risk.json, risk_samples.npz, ``stlc simulate``'s replan.json
  and executed.csv, and exactly the ``trajectory.<drone>.csv`` of the drones of the mission
  being written) and never removes anything else; ``-o .`` is safe.
* Ownership is decided by record, not by name pattern: every publish records the names
  of the set now in DIR in a manifest, ``.stlc-outputs.json`` (itself an owned name).  A
  later complete set removes only the files the previous manifest lists and this set does
  not have (a ``risk.json`` of a run with risk cases, a team's per-drone trajectories); a
  file with an owned-looking name that no manifest lists (a user's
  ``trajectory.final.csv``) is never removed.
* Each run writes its files into a private staging directory inside DIR
  (``.stlc-stage-XXXXXX``), then, holding an exclusive ``flock`` on DIR itself, moves them
  into place one by one with ``os.replace`` (atomic per file, same file system), then the
  manifest, then removes the stale recorded files, so concurrent runs on one DIR serialise
  their final step and DIR ends with one complete set, from the run that published last.
  On any error, Ctrl-C, SIGTERM or SIGHUP the staging directory (only the files this run
  wrote into it) is removed and DIR is untouched.
* ``preflight`` checks, before any solve, that DIR can be created or written: an empty
  name, a path through a file, a DIR that is a file, an owned name that is a directory, or
  a directory that refuses a new file gives STL605 (exit 1), located at the mission.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import re
import tempfile
from collections.abc import Iterator

from stlc import interrupt
from stlc.diagnostics import Diagnostic, Span, StlcError

#: every file name stlc may create or replace in an output directory, besides the
#: per-drone trajectories of a team plan, ``trajectory.<drone>.csv`` (only those of the
#: drones being written); removal is by record (``MANIFEST``), never by name
OWNED = ("solution.json", "trajectory.csv", "report.html", "risk.json", "risk_samples.npz",
         "replan.json", "executed.csv")
MANIFEST = ".stlc-outputs.json"
_PER_DRONE = re.compile(r"trajectory\.[A-Za-z_][A-Za-z0-9_]*\.csv")
STAGE_PREFIX = ".stlc-stage-"


def owned(name: str) -> bool:
    """Could ``name`` be one of stlc's outputs?  (A necessary condition for writing or
    removing it, not a sufficient one: see ``recorded``.)"""
    return name in OWNED or _PER_DRONE.fullmatch(name) is not None


def recorded(outdir: str) -> set[str]:
    """The output names the manifest of ``outdir`` lists (the set an earlier run
    published there); a missing or unreadable manifest lists nothing."""
    try:
        with open(os.path.join(outdir, MANIFEST), encoding="utf-8") as fh:
            data = json.loads(fh.read(1 << 16))
        files = data.get("files", []) if isinstance(data, dict) else []
    except (OSError, ValueError):
        return set()
    return {f for f in files if isinstance(f, str) and owned(f)}


def _fail(message: str, span: Span, help_: str) -> StlcError:
    return StlcError([Diagnostic("STL605", message, span, help_)])


def _probe(directory: str) -> str | None:
    """Why a new file cannot be created in the existing ``directory`` (None if it can)."""
    try:
        fd, path = tempfile.mkstemp(prefix=".stlc-probe-", dir=directory)
    except OSError as e:
        return e.strerror or str(e)
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(path)
    return None


def preflight(outdir: str, span: Span) -> None:
    """Raise ``StlcError`` (STL605) unless ``outdir`` exists as a writable directory or can
    be created; has no side effect on the file system (it creates nothing that stays)."""
    if not outdir:
        raise _fail("the output directory name is empty", span,
                    "give a directory with `-o DIR`, e.g. `-o reports`")
    path = os.path.abspath(outdir)
    if os.path.lexists(path) and not os.path.isdir(path):
        raise _fail(f"cannot write outputs to `{outdir}`: it is a file, not a directory", span,
                    "choose another directory with `-o DIR`")
    existing = path
    while not os.path.isdir(existing):
        parent = os.path.dirname(existing)
        if os.path.lexists(parent) and not os.path.isdir(parent):
            raise _fail(f"cannot create output directory `{outdir}`: `{parent}` is a file",
                        span, "choose a directory that is not inside a file")
        if parent == existing:
            break
        existing = parent
    why = _probe(existing)
    if why is not None:
        raise _fail(f"cannot write to output directory `{outdir}`: {why}", span,
                    f"check the permissions of `{existing}`, or choose another `-o DIR`")
    if existing == path:
        for name in (*OWNED, MANIFEST):
            p = os.path.join(path, name)
            if os.path.lexists(p) and not os.path.isfile(p):
                raise _fail(f"cannot replace `{p}`: it is not a regular file", span,
                            "stlc replaces only its own output files; move it away")


def _umask() -> int:
    old = os.umask(0o022)
    os.umask(old)
    return old


@contextlib.contextmanager
def _locked(directory: str) -> Iterator[None]:
    """An exclusive ``flock`` on the directory itself (no lock file left behind)."""
    fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def _cleanup(stage: str) -> None:
    """Remove what this run wrote into its staging directory, then the directory."""
    with contextlib.suppress(OSError):
        for name in os.listdir(stage):
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(stage, name))
        os.rmdir(stage)


def publish(stage: str, outdir: str, complete: bool = True) -> list[str]:
    """Move the files of ``stage`` into ``outdir`` (under the directory lock), record the
    set in the manifest and, when the stage is a ``complete`` set (``stlc compile``,
    ``simulate``), remove the files the previous manifest lists that this set does not
    have; ``stlc risk`` adds its two files to the recorded set.  Returns the names."""
    names = sorted(n for n in os.listdir(stage) if owned(n))
    mode = 0o666 & ~_umask()
    with _locked(outdir), interrupt.deferred():
        before = recorded(outdir)
        now = set(names) if complete else before | set(names)
        manifest = os.path.join(stage, MANIFEST)
        with open(manifest, "w", encoding="utf-8") as fh:
            json.dump({"written_by": "stlc", "files": sorted(now)}, fh, indent=1)
        for name in [*names, MANIFEST]:
            src = os.path.join(stage, name)
            os.chmod(src, mode)
            os.replace(src, os.path.join(outdir, name))
        for name in sorted(before - now):
            p = os.path.join(outdir, name)
            if os.path.isfile(p) and not os.path.islink(p):
                os.unlink(p)
    return names


@contextlib.contextmanager
def staged(outdir: str, span: Span, complete: bool = True) -> Iterator[str]:
    """Yield a private staging directory inside ``outdir`` to write a complete set of
    outputs into (with their final names); publish it when the block ends normally, discard
    it on any exception (also ``KeyboardInterrupt``).  File-system errors become STL605."""
    preflight(outdir, span)
    try:
        os.makedirs(outdir, exist_ok=True)
        stage = tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=outdir)
    except OSError as e:
        raise _fail(f"cannot create output directory `{outdir}`: {e.strerror or e}", span,
                    "choose another directory with `-o DIR`") from None
    try:
        yield stage
        publish(stage, outdir, complete)
    except OSError as e:
        raise _fail(f"cannot write outputs to `{outdir}`: {e.strerror or e}", span,
                    "check free space and permissions, or choose another `-o DIR`") from None
    finally:
        _cleanup(stage)
