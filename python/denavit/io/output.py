"""Writing outputs: whole or not at all, keeping what the user had, never replacing what is not a regular file.

- a regular file (or a new path) is written to a temporary file beside it (``.NAME.dvPID.XXXXXXXX.SUFFIX``) and
  renamed over it in one step, with the owner (uid, gid) and permissions of the file it replaces (a new
  file's: 0666 less the umask); when the owner cannot be kept (it is another user's and this one may not give
  files away), the write is refused rather than taking the file over;
- a read-only file (no write permission for this user, or none at all: mode 0444, even for root) is not
  replaced unless forced (``--force``, ``force=True``);
- a file with several hard links is not replaced (that would split them: the other names would keep the old
  content) unless forced, and then it is written through in place, so every name sees the new content (not
  atomic: the content is made whole in the temporary file first, then copied in);
- a symbolic link is followed: its target is written as above and the link is kept;
- ``-`` is standard output (closed: an error); a FIFO or a character device (``/dev/stdout``, a terminal,
  ``/dev/null``) is streamed to (there is nothing to rename over);
- anything else (a directory, a block device, a socket, a file of the kernel's /proc or /sys) is refused.

The temporary file is removed when the write fails, on SIGTERM or SIGHUP during the write (then the signal
does what it did before), and, left by a run killed outright (SIGKILL, a power cut), by the next write to the
same path: a file of exactly that name pattern whose writer process is gone and that has not changed for
:data:`STALE_SECONDS`, or that has not changed for :data:`ABANDONED_SECONDS` (its process id reused).

Every error names the user's path, never the temporary one. :func:`forcing` is how the command line's
``--force`` reaches every write of a command.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import stat
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import DenavitError

STDOUT = "-"
#: A temporary file of a writer whose process is gone is removed once it has not changed for this long (s).
STALE_SECONDS = 5.0
#: A temporary file that has not changed for this long (s) is removed whatever its process id (reused since).
ABANDONED_SECONDS = 3600.0
#: Filesystems of the kernel's interfaces: their files are not outputs, their directories take no new files.
KERNEL_FILESYSTEMS = frozenset(
    {
        "proc",
        "sysfs",
        "cgroup",
        "cgroup2",
        "debugfs",
        "tracefs",
        "securityfs",
        "configfs",
        "pstore",
        "efivarfs",
        "bpf",
        "devpts",
        "binfmt_misc",
        "fusectl",
        "selinuxfs",
        "mqueue",
    }
)
FORCE_HINT = "give --force (force=True in Python) to"

_forced = False  # set by forcing(): the command line's --force, for every write of the command


@contextmanager
def forcing(on: bool = True) -> Iterator[None]:
    """Every write inside the block is forced (``force=True``): what the command line's ``--force`` does."""
    global _forced  # noqa: PLW0603 (one flag for the command being run)
    old, _forced = _forced, bool(on)
    try:
        yield
    finally:
        _forced = old


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _filesystem(dev: int) -> str | None:
    """The type of the filesystem of device ``dev`` (an ``st_dev``), from /proc/self/mountinfo; None if unknown."""
    key = f"{os.major(dev)}:{os.minor(dev)}"
    try:
        with open("/proc/self/mountinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                fields = line.split()
                if len(fields) > 2 and fields[2] == key and " - " in line:
                    return line.split(" - ", 1)[1].split()[0]
    except OSError:
        pass
    return None


def _target(path: str | os.PathLike) -> tuple[Path, str, os.stat_result | None]:
    """(where to write, how: "stdout" | "stream" | "replace", its stat when it exists) for the user's ``path``."""
    if str(path) == STDOUT:
        return Path(STDOUT), "stdout", None
    p = Path(path)
    real = Path(os.path.realpath(p)) if p.is_symlink() else p
    try:
        st = real.stat()
    except FileNotFoundError:
        return real, "replace", None
    except NotADirectoryError as e:
        raise DenavitError(f"{path}: cannot write: {_why_not(real.parent, e)}") from None
    except OSError as e:
        raise DenavitError(f"{path}: cannot write: {e.strerror or e}") from None
    if stat.S_ISREG(st.st_mode):
        fs = _filesystem(st.st_dev)
        if fs in KERNEL_FILESYSTEMS:
            raise DenavitError(
                f"{path}: cannot write the output: {real} is a file of the kernel's {fs} filesystem, not a regular"
                " file; name a file on an ordinary filesystem"
            )
        return real, "replace", st
    if stat.S_ISFIFO(st.st_mode) or stat.S_ISCHR(st.st_mode):
        return real, "stream", st
    kind = (
        "a directory"
        if stat.S_ISDIR(st.st_mode)
        else (
            "a block device"
            if stat.S_ISBLK(st.st_mode)
            else "a socket"
            if stat.S_ISSOCK(st.st_mode)
            else "a special file"
        )
    )
    raise DenavitError(
        f"{path}: cannot write the output: it is {kind}, expected a regular file, a FIFO, a character device or '-'"
    )


def _admit(path, st: os.stat_result, force: bool) -> str:
    """How an existing regular file is written: "replace" or, a forced write of a multiply-linked file, "through";
    a read-only file or hard links without ``force`` are refused with one line saying what to do."""
    mode = stat.S_IMODE(st.st_mode)
    try:
        read_only_fs = bool(os.statvfs(path).f_flag & os.ST_RDONLY)
    except OSError:
        read_only_fs = False
    if read_only_fs:
        raise DenavitError(f"{path}: cannot write: it is on a read-only filesystem; write another file")
    if not force and (not mode & 0o222 or not os.access(path, os.W_OK)):
        why = (
            f"is read-only (mode {mode:04o})"
            if not mode & 0o222
            else f"is not writable by this user (mode {mode:04o}, owner uid {st.st_uid})"
        )
        raise DenavitError(f"{path}: {why}: not replaced; {FORCE_HINT} replace it, or write another file")
    if st.st_nlink > 1:
        if not force:
            raise DenavitError(
                f"{path}: has {st.st_nlink} hard links: replacing it would split them (the other names would keep the"
                f" old content); {FORCE_HINT} write through it in place (every name gets the new content), or write"
                " another file"
            )
        return "through"
    return "replace"


def _keep(fd: int, path, st: os.stat_result | None, mode: int | None = None) -> None:
    """Give the temporary file ``fd`` the owner of the file it replaces (``st``), or refuse in one line; with
    ``mode``, also that mode (after the owner: changing the owner clears set-id bits)."""
    if st is not None:
        own = os.fstat(fd)
        if (own.st_uid, own.st_gid) != (st.st_uid, st.st_gid):
            try:
                os.fchown(fd, st.st_uid, st.st_gid)
            except PermissionError:
                raise DenavitError(
                    f"{path}: cannot keep its owner (uid {st.st_uid}, gid {st.st_gid}): this user (uid {os.geteuid()})"
                    " may not give a file away, and replacing it would make it this user's; write it as its owner, or"
                    " write another file"
                ) from None
    if mode is not None:
        os.fchmod(fd, mode)


def _pattern(name: str, suffix: str) -> re.Pattern:
    """The names of this writer's temporary files for an output named ``name`` (and of its probes)."""
    return re.compile(rf"\.{re.escape(_stem(name))}\.dv([0-9]+)\.[a-z0-9_]{{8}}(?:{re.escape(suffix)}|\.probe)")


def _stem(name: str) -> str:
    return name[:180]  # the temporary name within the 255 bytes of a file name


def _suffix(target: Path) -> str:
    s = target.suffix
    return s if s and len(s) <= 16 else ".tmp"


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # another user's process: alive
    return True


def _clean_stale(target: Path) -> list[str]:
    """Remove the temporary files a killed run left beside ``target`` (the names :func:`_pattern` matches, whose
    writer is gone and that have not changed for :data:`STALE_SECONDS`, or for :data:`ABANDONED_SECONDS` at all);
    the names removed."""
    pattern, now, removed = _pattern(target.name, _suffix(target)), time.time(), []
    try:
        entries = list(os.scandir(target.parent))
    except OSError:
        return removed
    for e in entries:
        m = pattern.fullmatch(e.name)
        if m is None or e.path in _active:
            continue
        try:
            st = e.stat(follow_symlinks=False)
            age = now - st.st_mtime
            if stat.S_ISREG(st.st_mode) and (
                (age > STALE_SECONDS and not _alive(int(m[1]))) or age > ABANDONED_SECONDS
            ):
                os.unlink(e.path)
                removed.append(e.name)
        except OSError:
            continue
    return removed


def _temporary(path, parent: Path, name: str, suffix: str) -> tuple[int, str]:
    """A new empty hidden file beside the output (in ``parent``): its descriptor and name; or the one-line error
    that names the user's ``path`` and says why ``parent`` takes no new file."""
    try:
        return tempfile.mkstemp(dir=parent, prefix=f".{_stem(name)}.dv{os.getpid()}.", suffix=suffix)
    except OSError as e:
        raise DenavitError(f"{path}: cannot write: {_why_not(parent, e)}") from None


def _why_not(parent: Path, e: OSError) -> str:
    """Why no file can be created in ``parent`` (``e``: the system's refusal), said accurately."""
    try:
        st = parent.stat()
    except FileNotFoundError:
        return f"the directory {parent} does not exist"
    except NotADirectoryError:
        return f"{parent} is not a directory (a part of it is a file)"
    except OSError as e2:
        return f"the directory {parent} cannot be reached: {e2.strerror or e2}"
    if not stat.S_ISDIR(st.st_mode):
        return f"{parent} is not a directory"
    fs = _filesystem(st.st_dev)
    if fs in KERNEL_FILESYSTEMS:
        return (
            f"its directory {parent} is on the kernel's {fs} filesystem, where no file can be created; expected a"
            " directory on an ordinary filesystem"
        )
    return f"cannot create a file in the directory {parent}: {e.strerror or e}"


# -- the temporary files of writes in progress, removed on SIGTERM / SIGHUP --------------------------------

_active: set[str] = set()
_saved: dict[int, object] = {}  # signal -> the handler before ours, while ours is installed
_lock = threading.Lock()
_SIGNALS = tuple(getattr(signal, s) for s in ("SIGTERM", "SIGHUP") if hasattr(signal, s))


def _on_signal(signum: int, frame) -> None:  # noqa: ANN001 (a signal handler's frame)
    """Let the signal do what it did before: a handler of the program's is called (an exception it raises ends
    the write, which removes its temporary file); the default action (ending the process) comes after the
    temporary files of the writes in progress are removed and the previous handlers are put back."""
    previous = _saved.get(signum, signal.SIG_DFL)
    if callable(previous):
        previous(signum, frame)
        return
    for tmp in list(_active):
        try:
            os.unlink(tmp)
        except OSError:
            pass
    _active.clear()
    _restore()
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)
    time.sleep(1)
    os._exit(128 + signum)  # not reached: the default action ended the process


def _restore() -> None:
    for sig, previous in list(_saved.items()):
        if signal.getsignal(sig) is _on_signal:
            signal.signal(sig, previous)
    _saved.clear()


@contextmanager
def _registered(tmp: str) -> Iterator[None]:
    """``tmp`` is a write in progress: removed on SIGTERM or SIGHUP (handlers installed from the main thread
    while any write is in progress; a signal the process ignores stays ignored)."""
    main = threading.current_thread() is threading.main_thread()
    with _lock:
        _active.add(tmp)
        if main and not _saved:
            for sig in _SIGNALS:
                previous = signal.getsignal(sig)
                if previous not in (signal.SIG_IGN, None):
                    _saved[sig] = previous
                    signal.signal(sig, _on_signal)
    try:
        yield
    finally:
        with _lock:
            _active.discard(tmp)
            if main and not _active:
                _restore()


# -- the writers ---------------------------------------------------------------------------------------------


def check_writable(path: str | os.PathLike, *, force: bool = False) -> None:
    """Refuse, before any work is done, an output that :func:`atomic_path` could not write: a path whose kind it
    refuses, a read-only or multiply-linked file without ``force``, another user's file whose owner cannot be
    kept, a new or regular file in a directory that is missing or not writable (the same messages)."""
    force = force or _forced
    target, how, st = _target(path)
    if how != "replace":
        return
    through = st is not None and _admit(path, st, force) == "through"
    # a probe, as atomic_path will write (permission bits alone do not tell: root, sysfs, read-only mounts)
    fd, tmp = _temporary(path, target.parent, target.name, ".probe")
    try:
        _keep(fd, path, None if through else st)
    finally:
        os.close(fd)
        os.unlink(tmp)


def _closed_stdout() -> DenavitError:
    return DenavitError(
        "standard output: cannot write: it is closed; expected an open standard output (redirect it to a file, or to"
        " /dev/null to discard it)"
    )


@contextmanager
def atomic_path(path: str | os.PathLike, *, force: bool = False) -> Iterator[Path]:
    """A temporary path to write the output of ``path`` into; when the block ends without an error the output
    lands at ``path`` (see the module docstring for how, by the kind of file there; ``force``: replace a
    read-only file, write through a multiply-linked one); otherwise nothing is written and ``path`` is
    untouched."""
    force = force or _forced
    target, how, st = _target(path)
    if how == "stdout" and (sys.stdout is None or isinstance(sys.stdout, ClosedStdout)):
        raise _closed_stdout()
    if how == "replace":
        if st is not None:
            how = _admit(path, st, force)
        _clean_stale(target)
        parent = target.parent
    else:
        parent = Path(tempfile.gettempdir())
        _clean_stale(parent / target.name)
    fd, tmp = _temporary(path, parent, target.name, _suffix(target))
    try:
        with _registered(tmp):
            try:
                if how == "replace":
                    _keep(fd, path, st)  # refused before anything is written
            finally:
                os.close(fd)
            yield Path(tmp)
            if how == "replace":
                now = _stat_or_none(target)
                fd = os.open(tmp, os.O_RDONLY)
                try:
                    _keep(fd, path, now, stat.S_IMODE(now.st_mode) if now is not None else 0o666 & ~_umask())
                finally:
                    os.close(fd)
                os.replace(tmp, target)
            elif how == "through":
                with open(tmp, "rb") as src, open(target, "r+b") as dst:
                    shutil.copyfileobj(src, dst)
                    dst.truncate()
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


def _stat_or_none(p: Path) -> os.stat_result | None:
    try:
        return p.stat()
    except FileNotFoundError:
        return None


def write_text(path: str | os.PathLike, text: str, *, force: bool = False) -> None:
    """Write a whole text file (UTF-8) or nothing (:func:`atomic_path`; ``force``: replace a read-only file,
    write through a multiply-linked one)."""
    with atomic_path(path, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")


# -- standard output ----------------------------------------------------------------------------------------


class ClosedStdout:
    """``sys.stdout`` when the process started with its standard output closed (``denavit show kr5 >&-``):
    writing anything is an error (:func:`guard_stdout`), not a silent loss."""

    name = "<stdout>"
    closed = False

    def write(self, data) -> int:  # noqa: ANN001 (str or bytes)
        if not data:
            return 0
        raise _closed_stdout()

    def writelines(self, lines) -> None:  # noqa: ANN001 (an iterable of str)
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False

    def writable(self) -> bool:
        return True

    @property
    def buffer(self) -> ClosedStdout:
        return self

    encoding = "utf-8"
    errors = "strict"


def guard_stdout() -> None:
    """A process whose standard output is closed gets a :class:`ClosedStdout` (Python had set None, which
    print and rich write to silently) and descriptor 1 held on /dev/null read-only, so no file opened later
    takes its number and receives what was meant for standard output (a write to it fails)."""
    try:
        os.fstat(1)
        if sys.stdout is not None:
            return
    except OSError:
        try:
            fd = os.open(os.devnull, os.O_RDONLY)
            if fd != 1:
                os.close(fd)
        except OSError:
            pass
    sys.stdout = ClosedStdout()


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
