"""The ``denavit`` command line (typer + rich): one module per command, sharing :mod:`.common`, imported when
that command runs or shows its help (:data:`.common.COMMANDS`).

One grammar (docs/cli.md): ``--length mm|m`` and ``--angle deg|rad`` on every command (mm and degrees by
default), applied by :mod:`denavit.io.units`; ``--json [PATH]`` in SI; exit codes 0 / 1 (not met) / 2 (bad
input). Files are read and written by :mod:`denavit.io`. ``denavit --help`` loads typer and
rich only: numpy's heavy friends (scipy, matplotlib, yourdfpy) load inside the commands that need them.
"""

from __future__ import annotations

import sys

from ..errors import DenavitError
from .common import app, say

__all__ = ["app", "main"]


def main() -> None:
    """Entry point: every DenavitError becomes a one-line message and exit code 2."""
    try:
        app(prog_name="denavit")
    except DenavitError as e:
        say("bold red", "error:", f" {e}", err=True)
        sys.exit(2)
