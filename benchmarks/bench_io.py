"""Reading and writing sweep files (issue 41: "reading at the disk's pace", "simulate streams its rows").

Printed, median of ``--repeats`` runs, each in a process of its own (wall and CPU seconds, the peak resident memory
of that process, MB, imports included; ``OPENBLAS_NUM_THREADS=1``):

1. ``denavit simulate kr5 -o FILE --points N --noise 0.02 --noise-q 0.001`` (6 N rows written a piece at a time),
   for N of ``--points`` (default 10^4, 10^5, 10^6 per sweep).
2. Reading that file: :func:`denavit.read_sweeps` (the sweeps, SI, checked column-wise) beside the raw readers of
   its numbers: Arrow's CSV reader (``pyarrow.csv.read_csv``, multi-threaded, a table of float64 columns) and
   numpy's C reader (``numpy.loadtxt``; only up to ``--numpy-max`` points per sweep, it is the slowest).
3. The growth exponent of each from the smallest to the largest N (1: linear): of the wall time, of the CPU time
   (the wall time of a shared machine counts the waits for a core) and of the memory above the process's baseline
   (its peak after importing the reader alone).
4. :func:`denavit.io.measurements.read_measurements` of a calibration CSV (``q1..q6,x,y,z``) of 10^5 and 10^6 rows
   and the growth exponent of its CPU time.

Run ``python benchmarks/bench_io.py`` (``--repeats 3``, ``--points 10000,100000,1000000``; ``--only read``,
``--only simulate`` or ``--only measurements`` for one item). A file of 10^6 points per sweep is 1.04 GB, beyond the
default file size limit (1 GiB): the readers' processes run with ``DENAVIT_MAX_FILE_BYTES`` raised.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: What each reader's process runs: its imports (the baseline), then the read, timed.
READERS = {
    "denavit.read_sweeps": (
        "import denavit as dv, denavit.api, denavit.io.sweeps, pyarrow.csv",  # what a big file's reading loads
        "dv.read_sweeps(PATH)",
    ),
    "pyarrow.csv.read_csv": (
        "import pyarrow.csv as pc",
        "pc.read_csv(PATH, read_options=pc.ReadOptions(skip_rows=3, autogenerate_column_names=True))",
    ),
    "numpy.loadtxt": ("import numpy as np", "np.loadtxt(PATH, delimiter=',', skiprows=3)"),
}

PROBE = """
import json, sys, time
{imports}
PATH = sys.argv[1]
base = hwm()
w, c = time.perf_counter(), time.process_time()
{call}
w, c = time.perf_counter() - w, time.process_time() - c
print(json.dumps([w, c, hwm(), base]))
"""

#: The peak resident memory of the process, MB (``VmHWM``: its own, not the forking parent's as ``ru_maxrss``).
HWM = """
def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
"""

#: ``denavit ARGS`` in a process that prints its peak memory after the command (imports included).
CLI = """
import runpy, sys
sys.argv = ["denavit", *sys.argv[1:]]
try:
    runpy.run_module("denavit.cli", run_name="__main__")
except SystemExit as e:
    if e.code:
        raise
print(hwm())
"""


def env() -> dict:
    return {**os.environ, "OPENBLAS_NUM_THREADS": "1", "DENAVIT_MAX_FILE_BYTES": str(1 << 34)}


def median(xs):
    return sorted(xs)[len(xs) // 2]


def child(code: str, args: list[str]) -> tuple[float, str]:
    """Wall s and the last line printed of a Python process running ``code`` (with :data:`HWM`) on ``args``."""
    w = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", HWM + code, *args], env=env(), capture_output=True, text=True)
    if p.returncode:
        raise SystemExit(f"{' '.join(args)} failed: {p.stderr}")
    return time.perf_counter() - w, p.stdout.splitlines()[-1]


def simulate(n: int, path: Path, repeats: int) -> tuple[float, float, float]:
    """Wall s, CPU s (the children's) and peak MB of ``denavit simulate kr5 --points n``."""
    runs = []
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        w, last = child(
            CLI, ["simulate", "kr5", "-o", str(path), "--points", str(n), "--noise", "0.02", "--noise-q", "0.001"]
        )
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        runs.append((w, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, float(last)))
    return tuple(median([r[k] for r in runs]) for k in range(3))


def read(name: str, path: Path, repeats: int) -> tuple[float, float, float, float]:
    """Wall s, CPU s, peak MB and the baseline MB (after the imports) of reading ``path`` with reader ``name``."""
    imports, call = READERS[name]
    runs = [json.loads(child(PROBE.format(imports=imports, call=call), [str(path)])[1]) for _ in range(repeats)]
    return tuple(median([r[k] for r in runs]) for k in range(4))


def row(case: str, mb: float, w: float, c: float, peak: float | None, extra: str = "") -> None:
    shown = "-" if peak is None else f"{peak:.0f}"
    print(f"{case:<52} {mb:>8.1f} {w:>8.2f} {c:>8.2f} {shown:>9}{extra}", flush=True)


def exponent(a: float, b: float, na: int, nb: int) -> float:
    return math.log(b / a) / math.log(nb / na) if a > 0 and b > 0 else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--points", default="10000,100000,1000000", help="points per sweep, comma-separated")
    ap.add_argument("--numpy-max", type=int, default=100_000, help="largest points per sweep read by numpy.loadtxt")
    ap.add_argument("--measurement-rows", type=int, default=1_000_000, help="rows of the big measurement CSV")
    ap.add_argument("--only", choices=["simulate", "read", "measurements"], default=None)
    args = ap.parse_args()
    sizes = [int(x) for x in args.points.split(",")]
    print(f"{'case':<52} {'file MB':>8} {'wall s':>8} {'cpu s':>8} {'peak MB':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.only in (None, "measurements"):
            measurements(tmp, args.measurement_rows, args.repeats)
        if args.only == "measurements":
            return
        sim, reads = {}, {name: {} for name in READERS}
        for n in sizes:
            f = tmp / f"s{n}.csv"
            sim[n] = simulate(n, f, args.repeats if args.only != "read" else 1)
            mb = f.stat().st_size / 1e6
            if args.only != "read":
                row(f"simulate kr5 --points {n} (6 x {n} rows)", mb, *sim[n])
            if args.only == "simulate":
                continue
            for name in READERS:
                if name == "numpy.loadtxt" and n > args.numpy_max:
                    continue
                reads[name][n] = read(name, f, args.repeats)
                w, c, peak, base = reads[name][n]
                row(f"  {name}, 6 x {n} points", mb, w, c, peak, f"   (baseline {base:.0f} MB)")
            f.unlink()
        lo, hi = sizes[0], sizes[-1]
        if len(sizes) > 1:
            if args.only != "read":
                s0, s1 = sim[lo], sim[hi]
                print(
                    f"simulate growth {lo} -> {hi} points per sweep: exponent of the wall time "
                    f"{exponent(s0[0], s1[0], lo, hi):.2f}, of the CPU time {exponent(s0[1], s1[1], lo, hi):.2f}"
                )
            for name, r in reads.items():
                if lo in r and max(r) > lo:
                    top = max(r)
                    t = exponent(r[lo][0], r[top][0], lo, top)
                    c = exponent(r[lo][1], r[top][1], lo, top)
                    m = exponent(r[lo][2] - r[lo][3], r[top][2] - r[top][3], lo, top)
                    print(
                        f"{name} growth {lo} -> {top} points per sweep: exponent of the wall time {t:.2f}, "
                        f"of the CPU time {c:.2f}, of the memory above the baseline {m:.2f}"
                    )


def measurements(tmp: Path, rows: int, repeats: int) -> None:
    """Item 4: read_measurements of rows / 10 and rows rows, and the growth exponent of the CPU time."""
    from denavit.io.measurements import read_measurements

    rng = np.random.default_rng(0)
    cpu = []
    for n in (rows // 10, rows):
        f = tmp / f"m{n}.csv"
        table = np.column_stack([rng.uniform(-170, 170, (n, 6)), rng.uniform(-1500, 1500, (n, 3))])
        with f.open("w") as fh:
            fh.write("# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z\n")
            np.savetxt(fh, table, fmt="%.10g", delimiter=",")
        walls, cpus = [], []
        for _ in range(repeats):
            w, c = time.perf_counter(), time.process_time()
            read_measurements(f)
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c)
        cpu.append(median(cpus))
        row(
            f"read_measurements, {n} rows q1..q6,x,y,z (in process)",
            f.stat().st_size / 1e6,
            median(walls),
            cpu[-1],
            None,
        )
        f.unlink()
    print(f"read_measurements growth {rows // 10} -> {rows} rows: CPU exponent {exponent(cpu[0], cpu[1], 1, 10):.2f}")


if __name__ == "__main__":
    main()
