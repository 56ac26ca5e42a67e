"""Reading text files: UTF-8 (with or without a byte-order mark), decoded once, for every reader."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import DenavitError

BOM = b"\xef\xbb\xbf"


#: The bytes read at a time while a file's lines are checked against their limit.
CHUNK = 1 << 20


def read_bytes(path: str | os.PathLike, what: str = "file", *, lines: bool = False, head: int | None = None) -> bytes:
    """The bytes of ``path`` (at most ``head`` of them, if given); a missing, unreadable or non-regular file is a
    one-line :class:`DenavitError`, and so is a file beyond the size limit (:mod:`denavit.limits`,
    ``file_bytes``). With ``lines`` (a delimited file: CSV, a recording), a line beyond the line limit
    (``line_bytes``) is an error as soon as it is read: a 2 GB file of one line fails in the first megabytes."""
    from .. import limits  # noqa: PLC0415

    p = Path(path)
    try:
        with p.open("rb") as f:
            if head is not None:
                return f.read(head)
            size = os.fstat(f.fileno()).st_size
            limits.check_size(size, "file_bytes", str(p), f"bytes in the {what}")
            if not lines:
                return f.read()
            longest = limits.size("line_bytes")
            step = min(CHUNK, longest)  # a chunk no longer than the limit: only a line across chunks can exceed it
            chunks, run, line = [], 0, 1  # run: the bytes of line `line` read so far
            while chunk := f.read(step):
                chunks.append(chunk)
                first = chunk.find(b"\n")
                if first < 0:
                    run += len(chunk)
                else:
                    if run + first > longest:
                        break
                    line += chunk.count(b"\n")
                    run = len(chunk) - chunk.rfind(b"\n") - 1
                if run > longest:
                    break
            else:
                return b"".join(chunks)
            raise DenavitError(
                f"{p}: line {line} of the {what} is longer than the limit of {longest:,} bytes: not a delimited"
                " file of "
                f'rows? ({limits.raise_hint("line_bytes")}; docs/cli.md, "Limits")'
            )
    except FileNotFoundError:
        raise DenavitError(f"{p}: no such {what}") from None
    except IsADirectoryError:
        raise DenavitError(f"{p}: expected a {what}, got a directory") from None
    except OSError as e:
        raise DenavitError(f"{p}: cannot read the {what}: {e.strerror or e}") from None


def decode(data: bytes, where: str) -> str:
    """UTF-8 text of ``data`` (a leading byte-order mark is dropped); anything else names the byte offset."""
    if data.startswith(BOM):
        data = data[len(BOM) :]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        bad = data[e.start : e.start + 1].hex()
        hint = " (UTF-16: save it as UTF-8)" if data[:2] in (b"\xff\xfe", b"\xfe\xff") else " (save it as UTF-8)"
        raise DenavitError(f"{where}:{line}: not UTF-8 text: byte 0x{bad} at offset {e.start}{hint}") from None


def read_text(path: str | os.PathLike, what: str = "file", *, lines: bool = False) -> str:
    """The text of ``path``, decoded by :func:`decode`; ``lines``: as :func:`read_bytes` (a delimited file: each
    line within the line limit)."""
    return decode(read_bytes(path, what, lines=lines), str(path))
