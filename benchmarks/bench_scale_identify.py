"""How ``identify`` scales with the points per sweep (issue 12 "linear cost", issue 18's identify row).

For each size N (points per sweep, 6 sweeps of the KR5, Hayat et al.'s 90 degree protocol, 0.02 mm noise) the
long-form CSV is written once by ``denavit simulate``; then, in a fresh subprocess per size and repeat, the file is
read (:func:`denavit.io.sweeps.read_long_csv`) and identified with the default method (``auto``) beside the
nominal, as ``denavit identify FILE --nominal kr5`` does, and the measuring volume (the minimum bounding box) is
computed. Printed per size: the median over the repeats of the wall and CPU time of each stage, and the peak
resident memory of the subprocess (``resource.getrusage`` maxrss: everything, the interpreter included); then the
growth exponent between consecutive sizes (log time ratio / log size ratio: 1 = linear).

With ``--in-memory`` the sweeps are simulated in the subprocess instead (the same protocol, point noise 0.02 mm and
reading noise 0.001 deg, as ``denavit simulate kr5 --noise 0.02 --noise-q 0.001``) and identify alone is timed on
them (:func:`denavit.identify` on the SweepSet): the fit without the reader; ``sim MB`` is the peak while simulating,
and ``peak MB`` the peak during identify alone (Linux: the high-water mark reset after simulating; it counts the
sweeps held in memory, 72 bytes a point, and the interpreter).

Run ``python benchmarks/bench_scale_identify.py`` (``--sizes 1000,10000,100000,1000000``, ``--repeats 3``); on a
loaded machine set OPENBLAS_NUM_THREADS=1 (one core, as the issue's figures).

Measured (this machine, shared: load average 6-19, so CPU seconds compare; OPENBLAS_NUM_THREADS=1,
``--in-memory --no-box``, median of 3, before one run at 10^6; docs/speed.md, "Identify at a million points per
sweep"). Before: the fit of commit 2e39691, every step on all points; after: auto's choices on every k-th pose
beyond 50,000 points per sweep, then one fit on all points (issue 41)::

    N per sweep   before: identify CPU s   peak MB    after: identify CPU s   peak MB
          10000                     1.08       121                     0.92       121
         100000                     3.16       351                     2.54       277
        1000000                    35.0       2916                    12.2       1633

(peak MB before is the larger of the simulation's and identify's; after, identify's alone, with the sweeps, 432 MB at
10^6, the interpreter, and the heap the simulation left.) Growth exponent after, 10^5 -> 10^6: CPU 0.68, memory
0.99. End to end from the CSV (``denavit identify b.csv --nominal kr5``, 6 x 10^6 rows): 14.9 s CPU, 1.36 GB.
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

STAGES = ("read", "identify", "box")


def child(path: str, box: bool, in_memory: int = 0) -> None:
    """One measurement in this process: read (or simulate ``in_memory`` points per sweep), identify (auto), box;
    prints JSON."""
    import denavit as dv
    from denavit import load_robot
    from denavit import sweeps as sw
    from denavit.io import sweeps as swio

    out = {}
    kr5 = load_robot("kr5")

    def timed(name, f):
        w, c = time.perf_counter(), time.process_time()
        r = f()
        out[name] = (time.perf_counter() - w, time.process_time() - c)
        return r

    if in_memory:
        s = sw.simulate(
            kr5.model(),
            home=kr5.home,
            ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
            points_per_sweep=in_memory,
            noise=2e-5,
            noise_q=math.radians(0.001),
            seed=1,
        )
        out["sim_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        try:  # the peak resident memory from here on (Linux: VmHWM reset), so that identify's is not the simulation's
            with open("/proc/self/clear_refs", "w") as f:
                f.write("5")
        except OSError:
            pass
    else:
        s = timed("read", lambda: swio.read_long_csv(path, kinds=list(kr5.table.kinds)))
    res = timed("identify", lambda: dv.identify(s, nominal=kr5))
    if box:
        timed("box", lambda: res.box)
    out["method"] = res.method
    out["maxrss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    try:
        with open("/proc/self/status") as f:
            hwm = [line for line in f if line.startswith("VmHWM:")]
        if in_memory and hwm:
            out["maxrss_mb"] = int(hwm[0].split()[1]) / 1024
    except OSError:
        pass
    print(json.dumps(out))


def simulate(n: int, folder: Path) -> Path:
    f = folder / f"sweeps_{n}.csv"
    subprocess.run(
        [sys.executable, "-m", "denavit.cli", "simulate", "kr5", "-o", str(f), "--points", str(n), "--seed", "1"],
        check=True,
        capture_output=True,
    )
    return f


def median(v):
    v = sorted(v)
    return v[len(v) // 2] if len(v) % 2 else (v[len(v) // 2 - 1] + v[len(v) // 2]) / 2


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", default="1000,10000,100000,1000000", help="points per sweep, comma-separated")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-box", action="store_true", help="leave the bounding box out")
    ap.add_argument("--in-memory", action="store_true", help="simulate in memory and time identify alone")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--child-points", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child, not args.no_box, args.child_points)
        return
    sizes = [int(s) for s in args.sizes.split(",")]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    rows = []
    what = "simulated in memory" if args.in_memory else "from the long-form CSV"
    print(f"identify (auto, nominal kr5) {what}, 6 sweeps x N points; median of {args.repeats} runs, one process each")
    print(
        f"{'N':>9} {'sim MB' if args.in_memory else 'file MB':>8} "
        + " ".join(f"{s + ' s':>9} {s + ' cpu':>9}" for s in STAGES)
        + f" {'total s':>8} {'peak MB':>8}  method"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            f = None if args.in_memory else simulate(n, Path(tmp))
            runs = []
            for _ in range(args.repeats):
                cmd = [sys.executable, __file__, "--child", str(f or "-"), "--child-points", str(n if f is None else 0)]
                p = subprocess.run(
                    cmd + (["--no-box"] if args.no_box else []), check=True, capture_output=True, text=True, env=env
                )
                runs.append(json.loads(p.stdout.strip().splitlines()[-1]))
            st = {s: (median([r[s][0] for r in runs]), median([r[s][1] for r in runs])) for s in STAGES if s in runs[0]}
            total = median([sum(r[s][0] for s in STAGES if s in r) for r in runs])
            peak = median([r["maxrss_mb"] for r in runs])
            size = median([r["sim_mb"] for r in runs]) if f is None else f.stat().st_size / 1e6
            rows.append((n, st, total, peak))
            print(
                f"{n:>9} {size:>8.1f} "
                + " ".join(f"{st[s][0]:>9.2f} {st[s][1]:>9.2f}" if s in st else f"{'-':>9} {'-':>9}" for s in STAGES)
                + f" {total:>8.2f} {peak:>8.0f}  {runs[0]['method']}",
                flush=True,
            )
            if f is not None:
                f.unlink()
    print(
        "\ngrowth exponent between consecutive sizes (1 = linear; CPU time, and peak memory above the 1e3-point run's)"
    )
    base = rows[0][3]
    for (n0, s0, _, p0), (n1, s1, _, p1) in zip(rows, rows[1:]):
        k = math.log(n1 / n0)
        cpu = " ".join(f"{s} {math.log(max(s1[s][1], 1e-9) / max(s0[s][1], 1e-9)) / k:5.2f}" for s in s0)
        mem = math.log(max(p1 - base, 1.0) / max(p0 - base, 1.0)) / k if p0 - base > 1 else float("nan")
        print(f"{n0:>9} -> {n1:<9} {cpu}   memory {mem:5.2f}")


if __name__ == "__main__":
    main()
