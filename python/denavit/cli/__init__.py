"""The ``denavit`` command line (typer + rich): one module per command, sharing :mod:`.common`.

Units are declared at this edge (``--length``/``--angle``, ``--unit``/``--deg``) and applied by
:mod:`denavit.io.units`; files are read and written by :mod:`denavit.io`. ``denavit --help`` loads typer and
rich only: numpy's heavy friends (scipy, matplotlib, yourdfpy) load inside the commands that need them.
"""

from __future__ import annotations

import sys

from ..errors import DenavitError
from . import calibrate, compensate, convert, dynamics, fk, identify, ik, inspect, plan, show, simulate  # noqa: F401 (each registers its command)
from .common import app, say

__all__ = ["app", "main"]


def main() -> None:
    """Entry point: every DenavitError becomes a one-line message and exit code 2."""
    try:
        app()
    except DenavitError as e:
        say("bold red", "error:", f" {e}", err=True)
        sys.exit(2)
