"""Reading and writing sweep files (issue 18: "reading a 188 MB sweep CSV", ``simulate --points 500000``).

Printed, median of ``--repeats`` runs (wall and CPU seconds, peak resident memory of this process):

1. ``denavit simulate kr5 --points N`` as the command runs it: simulate the sweeps and write the long-form CSV
   (numbers with 17 digits, formatted a chunk of rows at a time), for N = 500,000 (3 million rows).
2. :func:`denavit.io.sweeps.read_long_csv` of a file of about 188 MB (6 x 333,333 points) on the C-speed path
   (Arrow's CSV reader, on both cores), and of a smaller one (6 x 50,000) on both paths: the same file with a comment line at its
   end is read row by row (the path that names the line and column of a bad cell), for the ratio.
3. :func:`denavit.io.measurements.read_measurements` of a calibration CSV (``q1..q6,x,y,z``) of 10^5 and 10^6
   rows on the C-speed path, and the growth exponent of its CPU time (1: linear; it had split every row in
   Python before trying a C reader).

Run ``python benchmarks/bench_io.py`` (``--repeats 3``, ``--points 500000``, ``--read-points 333333``,
``--measurement-rows 1000000``; ``--only measurements`` for item 3 alone).
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from denavit.io import sweeps as swio
from denavit.io.measurements import read_measurements


def timed(f, repeats):
    wall, cpu = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        f()
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return sorted(wall)[len(wall) // 2], sorted(cpu)[len(cpu) // 2]


def simulate(n: int, path: Path) -> tuple[float, float]:
    """Wall and CPU (children) seconds of ``denavit simulate kr5 -o path --points n``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "denavit.cli", "simulate", "kr5", "-o", str(path), "--points", str(n), "--seed", "1"],
        check=True,
        capture_output=True,
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter() - w, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--points", type=int, default=500_000, help="points per sweep of the simulate row")
    ap.add_argument("--read-points", type=int, default=333_333, help="points per sweep of the big file read")
    ap.add_argument("--measurement-rows", type=int, default=1_000_000, help="rows of the big measurement CSV")
    ap.add_argument("--only", choices=["measurements"], default=None, help="run one item alone")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print(f"{'case':<58} {'MB':>7} {'wall s':>8} {'cpu s':>8}")
        if args.only == "measurements":
            measurements(tmp, args.measurement_rows, args.repeats)
            return
        runs = [simulate(args.points, tmp / "sim.csv") for _ in range(args.repeats)]
        w, c = sorted(r[0] for r in runs)[len(runs) // 2], sorted(r[1] for r in runs)[len(runs) // 2]
        print(
            f"{f'simulate kr5 --points {args.points} (process, imports included)':<58} {(tmp / 'sim.csv').stat().st_size / 1e6:>7.1f} {w:>8.2f} {c:>8.2f}",
            flush=True,
        )
        (tmp / "sim.csv").unlink()
        big = tmp / "big.csv"
        simulate(args.read_points, big)
        w, c = timed(lambda: swio.read_long_csv(big), args.repeats)
        print(
            f"{f'read_long_csv, 6 x {args.read_points} points (C reader)':<58} {big.stat().st_size / 1e6:>7.1f} {w:>8.2f} {c:>8.2f}",
            flush=True,
        )
        big.unlink()
        small, slow = tmp / "small.csv", tmp / "slow.csv"
        simulate(50_000, small)
        slow.write_text(small.read_text() + "# a comment line at the end: read row by row\n")
        fast_t = timed(lambda: swio.read_long_csv(small), args.repeats)
        slow_t = timed(lambda: swio.read_long_csv(slow), args.repeats)
        print(
            f"{'read_long_csv, 6 x 50000 points (C reader)':<58} {small.stat().st_size / 1e6:>7.1f} {fast_t[0]:>8.2f} {fast_t[1]:>8.2f}"
        )
        print(
            f"{'read_long_csv, 6 x 50000 points (row by row, a comment at the end)':<58} {slow.stat().st_size / 1e6:>7.1f} {slow_t[0]:>8.2f} {slow_t[1]:>8.2f}"
            f"   ({slow_t[1] / fast_t[1]:.0f}x the C reader's CPU)"
        )
        measurements(tmp, args.measurement_rows, args.repeats)
    print(f"peak resident memory of this process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


def measurements(tmp: Path, rows: int, repeats: int) -> None:
    """Item 3: read_measurements of rows / 10 and rows rows, and the growth exponent of the CPU time."""
    rng = np.random.default_rng(0)
    cpu = []
    for n in (rows // 10, rows):
        f = tmp / f"m{n}.csv"
        table = np.column_stack([rng.uniform(-170, 170, (n, 6)), rng.uniform(-1500, 1500, (n, 3))])
        with f.open("w") as fh:
            fh.write("# units: length=mm angle=deg\nq1,q2,q3,q4,q5,q6,x,y,z\n")
            np.savetxt(fh, table, fmt="%.10g", delimiter=",")
        w, c = timed(lambda f=f: read_measurements(f), repeats)
        cpu.append(c)
        print(
            f"{f'read_measurements, {n} rows q1..q6,x,y,z (C reader)':<58} {f.stat().st_size / 1e6:>7.1f} {w:>8.2f} {c:>8.2f}",
            flush=True,
        )
        f.unlink()
    print(
        f"read_measurements growth, {rows // 10} -> {rows} rows: CPU x {cpu[1] / cpu[0]:.1f}, exponent {np.log10(cpu[1] / cpu[0]):.2f}"
    )


if __name__ == "__main__":
    main()
