"""The ``denavit`` command line (typer + rich): one module per command, sharing :mod:`.common`, imported when
that command runs or shows its help (:data:`.common.COMMANDS`).

One grammar (docs/cli.md): ``--length mm|m`` and ``--angle deg|rad`` on every command (mm and degrees by
default), applied by :mod:`denavit.io.units`; ``--json [PATH]`` in SI; exit codes 0 / 1 (not met) / 2 (bad
input). Files are read and written by :mod:`denavit.io`. ``denavit --help`` loads typer and
rich only: numpy's heavy friends (scipy, matplotlib, yourdfpy) load inside the commands that need them.
"""

from __future__ import annotations

import os
import signal
import sys
import warnings
from collections.abc import Sequence

from ..errors import DenavitError
from ..io.output import guard_stdout
from .common import app
from .console import say

__all__ = ["app", "execute", "main"]


def threading_main() -> bool:
    """Whether this is the main thread (the only one that may install a signal handler)."""
    import threading  # noqa: PLC0415

    return threading.current_thread() is threading.main_thread()


# (warnings.showwarning's signature)
def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ARG001
    say("bold yellow", "warning:", f" {message}", err=True)


class Interrupted(BaseException):
    """Ctrl-C (SIGINT) during a command: raised by the handler :func:`main` installs, so that click's own
    handling of KeyboardInterrupt ("Aborted!", exit 1, which means "goal not met") does not apply. The Rust
    core runs Python's handlers during long calls (``crates/denavit-py/src/signals.rs``)."""


def _interrupt(signum, frame) -> None:  # noqa: ARG001 (signal handler signature)
    raise Interrupted


def _flush_stdout() -> None:
    if sys.stdout is not None:
        try:
            sys.stdout.flush()
        except OSError as e:
            os.dup2(
                os.open(os.devnull, os.O_WRONLY), 1
            )  # what is left in the buffer goes nowhere: Python's own flush at exit would fail again
            raise OSError(e.errno, e.strerror, "standard output") from None


def execute(args: Sequence[str] | None = None) -> int:
    """Run ``denavit ARGS`` (default: the process's arguments) and return its exit code: every DenavitError, and any
    error of the operating system (a file, a folder, the disk), becomes a one-line message and exit code 2; anything
    else, a defect of denavit, a one-line message and exit code 3 (``DENAVIT_TRACEBACK=1`` shows its traceback, for a
    report). A warning raised by the library (e.g. a URDF's massless link with an inertia) is printed as one
    ``warning:`` line like the commands' own, without Python's file, line and source. The process's set-up (signals,
    a closed standard output) is :func:`main`'s; the tests run commands in-process through this function."""
    with warnings.catch_warnings():
        warnings.showwarning = _one_line_warning
        try:
            try:
                app(args=None if args is None else list(map(str, args)), prog_name="denavit")
            except SystemExit as e:
                _flush_stdout()  # what is still buffered: an error writing it (a full disk) is exit 2, not Python's 120
                return e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
        except Interrupted:
            say("bold red", "interrupted", "", err=True)
            return 130
        except DenavitError as e:
            say("bold red", "error:", f" {e}", err=True)
            return 2
        except OSError as e:
            where = f"{e.filename}: " if e.filename else ""
            say("bold red", "error:", f" {where}{e.strerror or e}", err=True)
            return 2
        except Exception as e:  # noqa: BLE001 (the last resort: no traceback reaches a user)
            if os.environ.get("DENAVIT_TRACEBACK"):
                raise
            say(
                "bold red",
                "error:",
                f" internal error, please report it with the command line: {type(e).__name__}: {e} "
                "(DENAVIT_TRACEBACK=1 shows where)",
                err=True,
            )
            return 3
    return 0


def main() -> None:
    """Entry point: the process's set-up, then :func:`execute`. A reader that stops (`denavit fk kr5 | head -1`)
    ends the command by SIGPIPE as it ends cat; Ctrl-C is exit 130; a closed standard output is an error when
    written to."""
    if hasattr(signal, "SIGPIPE"):  # the shell's status 141, not click's exit 1, which says "not met"
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    if threading_main():
        signal.signal(signal.SIGINT, _interrupt)  # Ctrl-C: exit 130 as a shell reports a command ended by SIGINT
    guard_stdout()  # a closed standard output (`denavit show kr5 >&-`) is an error when written to, not exit 0
    sys.exit(execute())
