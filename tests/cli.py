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
    p = subprocess.run([sys.executable, "-m", "denavit.cli", *map(str, args)], capture_output=True, text=True, env=env(columns), **kw)
    if ok:
        assert p.returncode == 0, p.stderr
    return p
