"""``stlc fmt FILE... [--check]`` / ``stlc fmt -``: the command around
``stlc.tools.fmt.format_text`` — each input read once (size-limited), only a regular file
rewritten, atomically (a temporary file in the same folder, then ``os.replace``)."""

from __future__ import annotations

import os
import sys
import tempfile

from stlc.diagnostics import StlcError, normalize_newlines
from stlc.tools.fmt import format_text



def write_atomic(path: str, text: str) -> None:
    """Replace ``path`` with ``text`` at once (same folder, same permissions)."""
    path = os.path.realpath(path)  # a symbolic link stays a link to the new text
    folder = os.path.dirname(path)
    mode = os.stat(path).st_mode & 0o7777
    fd, tmp = tempfile.mkstemp(prefix=".stlc-fmt-", suffix=".stl", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _cannot_write(f: str, why: str) -> StlcError:
    from stlc.diagnostics import Diagnostic, Span

    return StlcError([Diagnostic(
        "STL605", f"cannot reformat `{f}`: {why}", Span(f, 1, 1, 1, 2),
        "stlc fmt writes the new text beside the file and renames it over the old one "
        "(atomic): make the folder writable, or run `stlc fmt - < FILE > NEW` "
        "(or `stlc fmt --check FILE` to only check)")])


def run(files: list[str], check: bool = False) -> int:
    """``stlc fmt FILE... [--check]`` / ``stlc fmt -``: exit 0, or 1 when a file has errors
    (it is left untouched) or, with ``--check``, would change.  Each input is read once
    (size-limited), so a pipe, a process substitution or a FIFO is judged on what it
    sent; only a regular file is rewritten."""
    from stlc.diagnostics import render_all
    from stlc.frontend.syntax import decode
    from stlc.limits import MAX_SOURCE_BYTES, read_limited

    code = 0
    for f in files:
        src = None
        try:
            if f == "-":
                data = sys.stdin.buffer.read(MAX_SOURCE_BYTES + 1)
                if len(data) > MAX_SOURCE_BYTES:
                    from stlc.diagnostics import Diagnostic, Span
                    from stlc.limits import human

                    raise StlcError([Diagnostic(
                        "STL601", f"standard input is larger than the limit of "
                        f"{human(MAX_SOURCE_BYTES)}", Span("<stdin>", 1, 1, 1, 1),
                        "is this the .stl file you meant?")])
                src = decode(data, "<stdin>")
                out = format_text(src, "<stdin>")
                if check:
                    code |= out != normalize_newlines(src)
                else:
                    sys.stdout.write(out)
                continue
            data = read_limited(f, MAX_SOURCE_BYTES, "file",
                                "check the path; it must be a readable .stl file")
            src = decode(data, f)
            out = format_text(src, f)  # parses (else its diagnostics)
            if "\r\n" in src:  # a Windows file keeps its line ends
                out = out.replace("\n", "\r\n")
            if out == src:
                continue
            if check:
                print(f"would reformat {f}")
                code = 1
                continue
            if not os.path.isfile(f):
                raise _cannot_write(f, "it is not a regular file (a pipe or a device)")
            try:
                write_atomic(f, out)
            except OSError as e:
                raise _cannot_write(f, e.strerror or str(e)) from None
            print(f"reformatted {f}", file=sys.stderr)
        except StlcError as e:
            sources = {f: src} if src is not None else {}
            print(render_all(e.diagnostics, sources), file=sys.stderr)
            code = 1
    return code

