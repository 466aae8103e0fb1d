"""The output directory of ``stlc compile`` / ``simulate`` / ``risk`` / ``sweep``: what stlc
may write there, and how.

Contract (docs/outputs.md, "The output directory"):

* stlc writes only the files of its output set into DIR (``OWNED``: solution.json,
  trajectory.csv, report.html, risk.json, risk_samples.npz, ``stlc simulate``'s replan.json
  and executed.csv, and exactly the ``trajectory.<drone>.csv`` of the drones of the mission
  being written) and never removes anything else; ``-o .`` is safe.
* Ownership is decided by record, not by name pattern: every publish records the names
  of the set now in DIR in a manifest, ``.stlc-outputs.json`` (itself an owned name).  A
  later complete set removes only the files the previous manifest lists and this set does
  not have (a ``risk.json`` of a run with risk cases, a team's per-drone trajectories); a
  file with an owned-looking name that no manifest lists (a user's
  ``trajectory.final.csv``) is never removed.  ``stlc sweep``'s set (``SWEEP_OWNED`` and
  ``plans/<i>.csv``) is recorded under its own key of the same manifest (``FAMILIES``): a
  sweep replaces only what the last sweep wrote, a compile only what the last compile
  wrote, and neither removes the other's files (nor a user's ``plans/7.csv`` no sweep
  recorded).
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
         "replan.json", "executed.csv", "flight.json", "flown.csv")
MANIFEST = ".stlc-outputs.json"
_PER_DRONE = re.compile(r"trajectory\.[A-Za-z_][A-Za-z0-9_]*\.csv")
#: the flight-stack outputs (``stlc.flight.export``): one folder of per-drone setpoint
#: files and one ROS 2 bag folder; a file there that no manifest lists is not stlc's
#: (``preflight`` refuses to write over it)
FLIGHT_DIRS = ("flight", "rosbag2")
_FLIGHT = re.compile(r"flight/[A-Za-z_][A-Za-z0-9_]*\.(px4|mrs)\.csv"
                     r"|rosbag2/(metadata\.yaml|rosbag2\.mcap)")
STAGE_PREFIX = ".stlc-stage-"


#: ``stlc sweep``'s outputs, besides ``plans/<i>.csv`` (one per planned instance)
SWEEP_OWNED = ("sweep.csv", "sweep.json", "sweep.html")
_SWEEP_PLAN = re.compile(r"plans/[0-9]+\.csv")


def owned(name: str) -> bool:
    """Could ``name`` be one of stlc's outputs?  (A necessary condition for writing or
    removing it, not a sufficient one: see ``recorded``.)"""
    return (name in OWNED or _PER_DRONE.fullmatch(name) is not None
            or _FLIGHT.fullmatch(name) is not None)


def sweep_owned(name: str) -> bool:
    """Could ``name`` (relative, ``/``-separated) be one of ``stlc sweep``'s outputs?"""
    return name in SWEEP_OWNED or _SWEEP_PLAN.fullmatch(name) is not None


#: the manifest's keys, each an output set of its own (compile/simulate/risk; sweep) with
#: the names it may hold
FAMILIES = {"files": owned, "sweep": sweep_owned}


def _manifest(outdir: str) -> dict:
    try:
        with open(os.path.join(outdir, MANIFEST), encoding="utf-8") as fh:
            data = json.loads(fh.read(1 << 20))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def recorded(outdir: str, key: str = "files") -> set[str]:
    """The output names the manifest of ``outdir`` lists under ``key`` (the set an earlier
    run of that family published there); a missing or unreadable manifest lists nothing."""
    files = _manifest(outdir).get(key, [])
    ok = FAMILIES[key]
    return {f for f in files if isinstance(f, str) and ok(f)} if isinstance(files, list) \
        else set()


def foreign(outdir: str, names, key: str = "sweep") -> list[str]:
    """Those of ``names`` (relative) that exist in ``outdir`` although no manifest lists
    them under ``key``: a user's files with an output's name, which a run of that family
    must not replace (``plans/7.csv`` before a sweep that would write its instance 7)."""
    mine = recorded(outdir, key)
    return [n for n in names
            if n not in mine and os.path.lexists(os.path.join(outdir, n))]


def refuse_foreign(outdir: str, names, span: Span, key: str = "sweep") -> None:
    """STL605 when ``foreign`` finds any of ``names`` in ``outdir``."""
    found = foreign(outdir, names, key)
    if found:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise _fail(f"`{os.path.join(outdir, found[0])}`{more} exists and was not written by "
                    f"an earlier `stlc {key}` into `{outdir}`: stlc does not replace it",
                    span, "move the file away, or choose another `-o DIR`")


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


def preflight(outdir: str, span: Span, names: tuple[str, ...] = (*OWNED, MANIFEST),
              dirs: tuple[str, ...] = FLIGHT_DIRS) -> None:
    """Raise ``StlcError`` (STL605) unless ``outdir`` exists as a writable directory or can
    be created, where each of ``names`` that exists is a regular file and each of ``dirs``
    a directory; has no side effect on the file system (it creates nothing that stays)."""
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
        for name in names:
            p = os.path.join(path, name)
            if os.path.lexists(p) and not os.path.isfile(p):
                raise _fail(f"cannot replace `{p}`: it is not a regular file", span,
                            "stlc replaces only its own output files; move it away")
        for name in dirs:
            p = os.path.join(path, name)
            if os.path.lexists(p) and not os.path.isdir(p):
                raise _fail(f"cannot write into `{p}`: it is not a directory", span,
                            "move it away, or choose another `-o DIR`")
        if set(dirs) & set(FLIGHT_DIRS):
            _foreign_flight_files(path, span)


def _foreign_flight_files(path: str, span: Span) -> None:
    """A flight-stack output name that exists in ``path`` but no manifest lists was not
    written by stlc (a user's own bag in ``rosbag2/``): refuse rather than replace it."""
    mine = recorded(path)
    for d in FLIGHT_DIRS:
        folder = os.path.join(path, d)
        if not os.path.isdir(folder):
            continue
        for name in sorted(os.listdir(folder)):
            rel = f"{d}/{name}"
            if _FLIGHT.fullmatch(rel) and rel not in mine:
                raise _fail(f"cannot replace `{os.path.join(folder, name)}`: stlc did not "
                            "write it", span, "move it away, or choose another `-o DIR`")


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
    """Remove what this run wrote into its staging directory (and its sub-folders: a
    sweep's ``plans``), then the directory."""
    with contextlib.suppress(OSError):
        for name in os.listdir(stage):
            p = os.path.join(stage, name)
            if os.path.isdir(p) and not os.path.islink(p):
                _cleanup(p)
            with contextlib.suppress(OSError):
                os.unlink(p)
        os.rmdir(stage)


def _staged_names(stage: str) -> list[str]:
    """The files of ``stage``, relative and ``/``-separated (one level of sub-folders)."""
    out = []
    for name in os.listdir(stage):
        p = os.path.join(stage, name)
        if os.path.isdir(p):
            out += [f"{name}/{n}" for n in os.listdir(p)]
        else:
            out.append(name)
    return out


def publish(stage: str, outdir: str, complete: bool = True, key: str = "files") -> list[str]:
    """Move the files of ``stage`` into ``outdir`` (under the directory lock), record the
    set in the manifest under ``key`` (``FAMILIES``; the other families' records are kept)
    and, when the stage is a ``complete`` set (``stlc compile``, ``simulate``, ``sweep``),
    remove the files the previous manifest lists under ``key`` that this set does not
    have; ``stlc risk`` adds its two files to the recorded set.  Returns the names."""
    names = sorted(n for n in _staged_names(stage) if FAMILIES[key](n))
    mode = 0o666 & ~_umask()
    with _locked(outdir), interrupt.deferred():
        before = recorded(outdir, key)
        now = set(names) if complete else before | set(names)
        record = {k: sorted(recorded(outdir, k)) for k in FAMILIES if k != key}
        record = {k: v for k, v in record.items() if v}
        manifest = os.path.join(stage, MANIFEST)
        with open(manifest, "w", encoding="utf-8") as fh:
            json.dump({"written_by": "stlc", **record, key: sorted(now)}, fh, indent=1)
        theirs = [n for n in names if "/" in n and n not in before
                  and os.path.lexists(os.path.join(outdir, n))]
        if theirs:  # appeared after the preflight: a user's file is never replaced
            raise FileExistsError(17, f"`{theirs[0]}` exists and is not stlc's")
        for name in [*names, MANIFEST]:
            src = os.path.join(stage, name)
            dst = os.path.join(outdir, name)
            if "/" in name:
                os.makedirs(os.path.dirname(dst), exist_ok=True)
            os.chmod(src, mode)
            os.replace(src, dst)
        for name in sorted(before - now):
            p = os.path.join(outdir, name)
            if os.path.isfile(p) and not os.path.islink(p) \
                    and not os.path.islink(os.path.dirname(p)):
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
