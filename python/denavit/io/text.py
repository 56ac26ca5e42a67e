"""Reading text files: UTF-8 (with or without a byte-order mark), decoded once, for every reader."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import DenavitError

BOM = b"\xef\xbb\xbf"


def read_bytes(path: str | os.PathLike, what: str = "file") -> bytes:
    """The bytes of ``path``; a missing, unreadable or non-regular file is a one-line :class:`DenavitError`."""
    p = Path(path)
    try:
        return p.read_bytes()
    except FileNotFoundError:
        raise DenavitError(f"{p}: no such {what}") from None
    except IsADirectoryError:
        raise DenavitError(f"{p}: expected a {what}, got a directory") from None
    except OSError as e:
        raise DenavitError(f"{p}: cannot read the {what}: {e.strerror or e}") from None


def decode(data: bytes, where: str) -> str:
    """UTF-8 text of ``data`` (a leading byte-order mark is dropped); anything else names the byte offset."""
    if data.startswith(BOM):
        data = data[len(BOM):]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        bad = data[e.start:e.start + 1].hex()
        hint = " (UTF-16: save it as UTF-8)" if data[:2] in (b"\xff\xfe", b"\xfe\xff") else " (save it as UTF-8)"
        raise DenavitError(f"{where}:{line}: not UTF-8 text: byte 0x{bad} at offset {e.start}{hint}") from None


def read_text(path: str | os.PathLike, what: str = "file") -> str:
    """The text of ``path``, decoded by :func:`decode`."""
    return decode(read_bytes(path, what), str(path))
