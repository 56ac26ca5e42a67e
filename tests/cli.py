"""Running the command line as a user would: in-process by default (:func:`run`, through
:func:`denavit.cli.execute`, the entry point's own error handling, a console of the given width, warnings as a fresh
process shows them), and as a subprocess with a plain environment for the few end-to-end tests of the entry point
itself (:func:`run_process`: exit codes, signals, closed streams)."""

import contextlib
import io
import os
import subprocess
import sys
import warnings
from types import SimpleNamespace


def env(columns: int = 120) -> dict:
    """A user's environment: a terminal width, a PATH, and the PYTHONPATH of the test run (if any), so the
    subprocess imports the same denavit as the tests."""
    e = {"COLUMNS": str(columns), "PATH": "/usr/bin:/bin"}
    if os.environ.get("PYTHONPATH"):
        e["PYTHONPATH"] = os.environ["PYTHONPATH"]
    return e


def run_process(*args, ok: bool = True, columns: int = 120, **kw) -> subprocess.CompletedProcess:
    """``denavit ARGS...`` in a subprocess (``python -m denavit.cli``); with ``ok`` the exit code must be 0."""
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", *map(str, args)], capture_output=True, text=True, env=env(columns), **kw
    )
    if ok:
        assert p.returncode == 0, p.stderr
    return p


#: Python's default warning filters (a fresh process's), for the in-process runs: pytest's own ("error") would
#: turn a library warning the command line prints as one line into an exception.
_DEFAULT_FILTERS = (
    ("default", None),
    ("ignore", DeprecationWarning),
    ("ignore", PendingDeprecationWarning),
    ("ignore", ImportWarning),
    ("ignore", ResourceWarning),
)


def _stream() -> io.TextIOWrapper:
    """A text stream with a binary ``buffer`` underneath, as a process's standard output has (``--save -`` writes
    bytes)."""
    return io.TextIOWrapper(io.BytesIO(), encoding="utf-8", write_through=True)


def _text(stream: io.TextIOWrapper) -> str:
    stream.flush()
    return stream.buffer.getvalue().decode("utf-8")


def run(*args, ok: bool = True, columns: int = 120) -> SimpleNamespace:
    """``denavit ARGS...`` in this process (:func:`denavit.cli.execute`): ``returncode``, ``stdout``, ``stderr`` as a
    subprocess's; with ``ok`` the exit code must be 0 (stderr shown otherwise). The consoles write to this run's
    streams at ``columns`` wide, whatever an earlier test left them pointing at."""
    from denavit.cli import console as terminal
    from denavit.cli import execute

    out, err = _stream(), _stream()
    consoles = (terminal.console, terminal.err_console)
    widths = [c.width for c in consoles]
    saved_env = {k: os.environ.get(k) for k in ("COLUMNS", "LINES", "TERMINAL_WIDTH", "FORCE_COLOR", "NO_COLOR")}
    os.environ["COLUMNS"] = str(columns)
    for k in ("LINES", "TERMINAL_WIDTH", "FORCE_COLOR", "NO_COLOR"):
        os.environ.pop(k, None)
    for c in consoles:
        c.file, c.width = None, columns  # None: the current sys.stdout / sys.stderr
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            warnings.resetwarnings()
            for action, category in reversed(_DEFAULT_FILTERS):
                warnings.simplefilter(action, category or Warning)
            code = execute([str(a) for a in args])
    finally:
        for c, w in zip(consoles, widths):
            c.file, c.width = None, w  # None: the streams of the moment, as when the module was imported
        for k, v in saved_env.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    p = SimpleNamespace(args=list(args), returncode=code, stdout=_text(out), stderr=_text(err))
    if ok:
        assert p.returncode == 0, p.stderr
    return p


def error_line(stderr: str) -> str | None:
    """The one error line of a failed command's stderr, or None when there is not exactly one (or a traceback).

    A step that lasts over a second says what it is doing on stderr, one line when not on a terminal (docs/cli.md,
    "Terminal output": every such line ends its message with "..."); those may come before the error, which must be
    the last line, alone, starting with "error: "."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if not lines or "Traceback" in stderr or not lines[-1].startswith("error: "):
        return None
    if any(ln.startswith("error") or "..." not in ln for ln in lines[:-1]):
        return None
    return lines[-1]
