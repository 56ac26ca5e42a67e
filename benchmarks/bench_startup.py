"""Start-up cost of the command line and the package (issue 18: "`denavit --help` / `import denavit`: <= 0.3 s,
no scipy").

Printed: the median CPU seconds (user + system of the child process) over ``--repeats`` fresh interpreters of

* ``python -c pass``, ``import click``, ``import typer`` and ``import typer, rich.console`` (the floor: typer
  and the console every command prints with), ``import typer, typer.rich_utils`` (typer's help formatter as
  typer imports it, with rich.markdown and rich.traceback, markdown-it and pygments behind them, which the
  command line leaves out),
* ``import denavit`` (the Rust core only: the workflows load on first use),
* ``denavit --help``, ``denavit fk --help``, ``denavit identify --help`` (the longest help), ``denavit --version``
  (run as the console script runs them),

and whether numpy / scipy were imported (``-X importtime``), and whether denavit's bytecode was cached (with
PYTHONDONTWRITEBYTECODE set and no ``__pycache__``, every run compiles the modules it imports, as an installed
package does not). Run ``python benchmarks/bench_startup.py`` (``--repeats 15``).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import resource
import statistics
import subprocess
import sys

CLI = "import sys; from denavit.cli import main; sys.argv = ['denavit', *sys.argv[1:]]; main()"


def cpu(args: list[str], repeats: int) -> float:
    """The median CPU seconds of running ``args`` (a fresh interpreter each time)."""
    env = {**os.environ, "COLUMNS": "80"}
    times = []
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        times.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(times)


def imported(args: list[str]) -> list[str]:
    """The heavy top-level packages ``args`` imports (of numpy, scipy, matplotlib)."""
    p = subprocess.run(
        [args[0], "-X", "importtime", *args[1:]],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "80"},
        check=True,
    )
    mods = {ln.split("|")[-1].strip() for ln in p.stderr.splitlines() if ln.startswith("import time:")}
    return [m for m in ("numpy", "scipy", "matplotlib") if m in mods]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    a = ap.parse_args()
    py = sys.executable
    cases = [
        ("python -c pass", [py, "-c", "pass"], None),
        ("import click", [py, "-c", "import click"], None),
        ("import typer", [py, "-c", "import typer"], None),
        ("import typer, rich.console (floor)", [py, "-c", "import typer, rich.console"], None),
        ("import typer, typer.rich_utils", [py, "-c", "import typer, typer.rich_utils"], None),
        ("import denavit", [py, "-c", "import denavit"], None),
        ("denavit --help", [py, "-c", CLI, "--help"], 0.3),
        ("denavit fk --help", [py, "-c", CLI, "fk", "--help"], None),
        ("denavit identify --help", [py, "-c", CLI, "identify", "--help"], None),
        ("denavit --version", [py, "-c", CLI, "--version"], None),
    ]
    common = importlib.util.find_spec("denavit.cli.common").origin
    cached = os.path.exists(importlib.util.cache_from_source(common))
    print(
        f"denavit from {os.path.dirname(os.path.dirname(common))}, bytecode"
        f" {'cached' if cached else 'NOT cached (compiled at every run)'}\n"
    )
    print(f"| case | CPU median [s] ({a.repeats} runs) | imports | target |")
    print("|---|---|---|---|")
    for name, args, target in cases:
        t = cpu(args, a.repeats)
        heavy = ", ".join(imported(args)) or "no numpy/scipy"
        print(
            f"| {name} | {t:.3f} | {heavy} | "
            + ("" if target is None else f"<= {target} s: {'met' if t <= target else 'NOT met'}")
            + " |"
        )


if __name__ == "__main__":
    main()
