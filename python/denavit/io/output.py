"""Writing outputs: whole or not at all, never replacing what is not a regular file.

- a regular file (or a new path) is written to a temporary file beside it and renamed over it in one step,
  with the permissions of the file it replaces (a new file's: 0666 less the umask);
- a symbolic link is followed: its target is written as above and the link is kept;
- ``-`` is standard output; a FIFO or a character device (``/dev/stdout``, a terminal, ``/dev/null``) is
  streamed to (there is nothing to rename over);
- anything else (a directory, a block device, a socket) is refused.

Every error names the user's path, never the temporary one.
"""

from __future__ import annotations

import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import DenavitError

STDOUT = "-"


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _target(path: str | os.PathLike) -> tuple[Path, str]:
    """(where to write, how: "stdout" | "stream" | "replace") for the user's ``path``."""
    if str(path) == STDOUT:
        return Path(STDOUT), "stdout"
    p = Path(path)
    try:
        real = Path(os.path.realpath(p)) if p.is_symlink() else p
        st = real.stat()
    except FileNotFoundError:
        return (Path(os.path.realpath(p)) if p.is_symlink() else p), "replace"
    except OSError as e:
        raise DenavitError(f"{path}: cannot write: {e.strerror or e}") from None
    if stat.S_ISREG(st.st_mode):
        return real, "replace"
    if stat.S_ISFIFO(st.st_mode) or stat.S_ISCHR(st.st_mode):
        return real, "stream"
    kind = "a directory" if stat.S_ISDIR(st.st_mode) else "a block device" if stat.S_ISBLK(st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode) else "a special file"
    raise DenavitError(f"{path}: cannot write the output: it is {kind}, expected a regular file, a FIFO, a character device or '-'")


def _temporary(path, parent: Path, name: str, suffix: str) -> str:
    """A new empty hidden file beside the output (in ``parent``), or the error that names the user's ``path``."""
    try:
        fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{name}.", suffix=suffix)
    except FileNotFoundError:
        raise DenavitError(f"{path}: cannot write: the directory {parent} does not exist") from None
    except OSError as e:
        raise DenavitError(f"{path}: cannot write in {parent}: {e.strerror or e}") from None
    os.close(fd)
    return tmp


def check_writable(path: str | os.PathLike) -> None:
    """Refuse, before any work is done, an output that :func:`atomic_path` could not write: a path whose kind it
    refuses, or a new or regular file in a directory that is missing or not writable (the same messages)."""
    target, how = _target(path)
    if how != "replace":
        return
    # a probe, as atomic_path will write (permission bits alone do not tell: root, sysfs, read-only mounts)
    os.unlink(_temporary(path, target.parent, target.name, ".probe"))


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write the output of ``path`` into; when the block ends without an error the output
    lands at ``path`` (see the module docstring for how, by the kind of file there); otherwise nothing is
    written and ``path`` is untouched."""
    target, how = _target(path)
    parent = target.parent if how == "replace" else Path(tempfile.gettempdir())
    suffix = target.suffix or ".tmp"
    tmp = _temporary(path, parent, target.name, suffix)
    try:
        yield Path(tmp)
        if how == "replace":
            os.chmod(tmp, target.stat().st_mode & 0o7777 if target.exists() else 0o666 & ~_umask())
            os.replace(tmp, target)
        elif how == "stdout":
            sys.stdout.flush()
            with open(tmp, "rb") as src:
                shutil.copyfileobj(src, sys.stdout.buffer)
            sys.stdout.buffer.flush()
        else:
            with open(tmp, "rb") as src, open(target, "wb") as dst:
                shutil.copyfileobj(src, dst)
    except OSError as e:
        raise DenavitError(f"{path}: cannot write: {e.strerror or e}") from None
    finally:
        Path(tmp).unlink(missing_ok=True)


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write a whole text file (UTF-8) or nothing (:func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _strict(value):
    """``value`` with every non-finite float (NaN, +-inf, numpy's too) as None, numpy scalars and arrays as
    Python numbers and lists: what strict JSON (RFC 8259) can hold."""
    import math  # noqa: PLC0415

    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return _strict(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def json_text(doc) -> str:
    """Strict JSON of ``doc`` (indent 2, a final newline): NaN and infinities become ``null`` (bare ``NaN`` is
    not JSON), numpy values plain numbers. Every JSON output of denavit is written through it."""
    import json  # noqa: PLC0415

    return json.dumps(_strict(doc), indent=2, allow_nan=False) + "\n"
