"""What a command writes: ``--json [PATH]`` (standard output or a file, in SI), the checks of the files a command
names before the work starts, and the plot extra a ``--report`` / ``--plot`` needs."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

from ..errors import DenavitError
from .console import console, fail, say, wrote

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np


#: What a bare ``--json`` (no PATH after it) means: standard output.
STDOUT = "-"


SI_UNITS = {"length": "m", "angle": "rad"}


def json_argv(argv: Sequence[str]) -> list[str]:
    """``--json`` with no value (last, or followed by another option) becomes ``--json -``: ``--json [PATH]``
    on every command (click has no optional option values)."""
    out: list[str] = []
    for k, a in enumerate(argv):
        out.append(a)
        if a == "--":
            return out + list(argv[k + 1 :])
        if a == "--json":
            nxt = argv[k + 1] if k + 1 < len(argv) else None
            if nxt is None or (nxt.startswith("-") and nxt != STDOUT):
                out.append(STDOUT)
    return out


def check_outputs(**paths) -> None:
    """The files a command writes, by option name (``check_outputs(**{"--save": save, "--json": json})``): at most
    one on standard output ('-'), which then holds that document only (tables, notes and ``wrote`` lines go to
    stderr; two had been written one after the other into one stream), and no file named twice (the second
    write had replaced the first without a word)."""
    given = {opt: str(p) for opt, p in paths.items() if p is not None}
    std = [opt for opt, p in given.items() if p == STDOUT]
    if len(std) > 1:
        fail(f"{' and '.join(std)}: both write to standard output ('-'): give a file to all but one")
    if std:
        console.file = sys.stderr
    seen: dict[str, str] = {}
    for opt, p in given.items():
        key = os.path.realpath(p) if p != STDOUT else None
        if key is not None and key in seen:
            fail(f"{seen[key]} and {opt} both write {p}: give each its own file")
        if key is not None:
            seen[key] = opt


def json_target(path) -> str | None:
    """Where ``--json`` goes (None: nowhere). To standard output, it replaces the tables and everything else
    printed (notes, warnings, ``wrote``) goes to stderr, so standard output holds the JSON document only."""
    if path is None:
        return None
    path = str(path)
    if path == STDOUT:
        console.file = sys.stderr
    return path


def emit_json(doc, path: str | None) -> None:
    """Write ``doc`` (SI, ``units`` stated) as strict JSON to ``path`` ('-': standard output)."""
    from ..io.output import json_text, write_text  # noqa: PLC0415

    if path is None:
        return
    text = json_text(doc)
    if path == STDOUT:
        sys.stdout.write(text)
        sys.stdout.flush()
    else:
        write_text(path, text)
        wrote(path)


def pose_rows(T: np.ndarray, ls: float) -> list[list[float]]:
    import numpy as np  # noqa: PLC0415

    M = np.array(T, dtype=float)
    M[:3, 3] /= ls
    return M.tolist()


def require_plot_extra(report=None, plot=None) -> None:
    """Before any work: ``--report`` needs plotly and ``--plot`` matplotlib (the ``plot`` extra); a missing one is a
    one-line error with the command that installs it for this installation (:func:`denavit.plotting.install_hint`),
    not a failure after the fit (issue 40)."""
    import importlib.util  # noqa: PLC0415

    need = [(opt, mod) for opt, given, mod in (("--report", report, "plotly"), ("--plot", plot, "matplotlib")) if given]

    def absent(mod: str) -> bool:
        try:
            return importlib.util.find_spec(mod) is None
        except (ImportError, ValueError):  # a broken or blocked installation is no installation
            return True

    missing = [(opt, mod) for opt, mod in need if absent(mod)]
    if missing:
        from ..plotting import install_hint  # noqa: PLC0415

        what = ", ".join(f"{opt} needs {mod}" for opt, mod in missing)
        raise DenavitError(f"{what}, which is not installed: {install_hint()}")


def save_urdf_of(model, path, robot) -> None:
    """``--urdf``: the model as URDF (:func:`denavit.io.urdf.save_urdf`), and a note when the robot's joints are
    compliant (issue 37): a URDF has no place for the compliances, so compensating with it is the rigid arm's."""
    from ..io.urdf import save_urdf  # noqa: PLC0415

    save_urdf(model, path, robot)
    wrote(path)
    k = getattr(robot, "compliance", None)
    if k is not None and any(v > 0 for v in k):
        say(
            "yellow",
            "note:",
            f" {path}: a URDF carries no joint compliances (the robot file of --save does): compensate or validate"
            " with it and the joints are taken as rigid",
        )
