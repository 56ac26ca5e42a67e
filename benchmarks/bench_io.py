"""Reading and writing sweep files (issue 18: "reading a 188 MB sweep CSV", ``simulate --points 500000``).

Printed, median of ``--repeats`` runs (wall and CPU seconds, peak resident memory of this process):

1. ``denavit simulate kr5 --points N`` as the command runs it: simulate the sweeps and write the long-form CSV
   (numbers with 17 digits, formatted a chunk of rows at a time), for N = 500,000 (3 million rows).
2. :func:`denavit.io.sweeps.read_long_csv` of a file of about 188 MB (6 x 333,333 points) on the C-speed path
   (numpy's reader), and of a smaller one (6 x 50,000) on both paths: the same file with a comment line at its
   end is read row by row (the path that names the line and column of a bad cell), for the ratio.

Run ``python benchmarks/bench_io.py`` (``--repeats 3``, ``--points 500000``, ``--read-points 333333``).
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from denavit.io import sweeps as swio


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
    subprocess.run([sys.executable, "-m", "denavit.cli", "simulate", "kr5", "-o", str(path), "--points", str(n), "--seed", "1"], check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter() - w, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--points", type=int, default=500_000, help="points per sweep of the simulate row")
    ap.add_argument("--read-points", type=int, default=333_333, help="points per sweep of the big file read")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print(f"{'case':<58} {'MB':>7} {'wall s':>8} {'cpu s':>8}")
        runs = [simulate(args.points, tmp / "sim.csv") for _ in range(args.repeats)]
        w, c = sorted(r[0] for r in runs)[len(runs) // 2], sorted(r[1] for r in runs)[len(runs) // 2]
        print(f"{f'simulate kr5 --points {args.points} (process, imports included)':<58} {(tmp / 'sim.csv').stat().st_size / 1e6:>7.1f} {w:>8.2f} {c:>8.2f}", flush=True)
        (tmp / "sim.csv").unlink()
        big = tmp / "big.csv"
        simulate(args.read_points, big)
        w, c = timed(lambda: swio.read_long_csv(big), args.repeats)
        print(f"{f'read_long_csv, 6 x {args.read_points} points (numpy C reader)':<58} {big.stat().st_size / 1e6:>7.1f} {w:>8.2f} {c:>8.2f}", flush=True)
        big.unlink()
        small, slow = tmp / "small.csv", tmp / "slow.csv"
        simulate(50_000, small)
        slow.write_text(small.read_text() + "# a comment line at the end: read row by row\n")
        fast_t = timed(lambda: swio.read_long_csv(small), args.repeats)
        slow_t = timed(lambda: swio.read_long_csv(slow), args.repeats)
        print(f"{'read_long_csv, 6 x 50000 points (numpy C reader)':<58} {small.stat().st_size / 1e6:>7.1f} {fast_t[0]:>8.2f} {fast_t[1]:>8.2f}")
        print(f"{'read_long_csv, 6 x 50000 points (row by row, a comment at the end)':<58} {slow.stat().st_size / 1e6:>7.1f} {slow_t[0]:>8.2f} {slow_t[1]:>8.2f}"
              f"   ({slow_t[1] / fast_t[1]:.0f}x the C reader's CPU)")
    print(f"peak resident memory of this process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
