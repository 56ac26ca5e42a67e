"""Running the command line as a user would: a subprocess each, with a plain environment."""

import os
import subprocess
import sys


def env(columns: int = 120) -> dict:
    """A user's environment: a terminal width, a PATH, and the PYTHONPATH of the test run (if any), so the
    subprocess imports the same denavit as the tests."""
    e = {"COLUMNS": str(columns), "PATH": "/usr/bin:/bin"}
    if os.environ.get("PYTHONPATH"):
        e["PYTHONPATH"] = os.environ["PYTHONPATH"]
    return e


def run(*args, ok: bool = True, columns: int = 120, **kw) -> subprocess.CompletedProcess:
    """``denavit ARGS...``; with ``ok`` the exit code must be 0 (stderr shown otherwise)."""
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", *map(str, args)], capture_output=True, text=True, env=env(columns), **kw
    )
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
