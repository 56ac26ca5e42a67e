"""How ``identify`` scales with the points per sweep (issue 12 "linear cost", issue 18's identify row).

For each size N (points per sweep, 6 sweeps of the KR5, Hayat et al.'s 90 degree protocol, 0.02 mm noise) the
long-form CSV is written once by ``denavit simulate``; then, in a fresh subprocess per size and repeat, the file is
read (:func:`denavit.io.sweeps.read_long_csv`) and identified with the default method (``auto``) beside the
nominal, as ``denavit identify FILE --nominal kr5`` does, and the measuring volume (the minimum bounding box) is
computed. Printed per size: the median over the repeats of the wall and CPU time of each stage, and the peak
resident memory of the subprocess (``resource.getrusage`` maxrss: everything, the interpreter included); then the
growth exponent between consecutive sizes (log time ratio / log size ratio: 1 = linear).

Run ``python benchmarks/bench_scale_identify.py`` (``--sizes 1000,10000,100000,1000000``, ``--repeats 3``); on a
loaded machine set OPENBLAS_NUM_THREADS=1 (one core, as the issue's figures).
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

STAGES = ("read", "identify", "box")


def child(path: str, box: bool) -> None:
    """One measurement in this process: read, identify (auto), box; prints JSON."""
    import denavit as dv
    from denavit import load_robot
    from denavit.io import sweeps as swio

    out = {}
    kr5 = load_robot("kr5")

    def timed(name, f):
        w, c = time.perf_counter(), time.process_time()
        r = f()
        out[name] = (time.perf_counter() - w, time.process_time() - c)
        return r

    s = timed("read", lambda: swio.read_long_csv(path, kinds=list(kr5.table.kinds)))
    res = timed("identify", lambda: dv.identify(s, nominal=kr5))
    if box:
        timed("box", lambda: res.box)
    out["method"] = res.method
    out["maxrss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
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
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child, not args.no_box)
        return
    sizes = [int(s) for s in args.sizes.split(",")]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    rows = []
    print(
        f"identify (auto, nominal kr5) from the long-form CSV, 6 sweeps x N points; median of {args.repeats} runs, one process each"
    )
    print(
        f"{'N':>9} {'file MB':>8} "
        + " ".join(f"{s + ' s':>9} {s + ' cpu':>9}" for s in STAGES)
        + f" {'total s':>8} {'peak MB':>8}  method"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            f = simulate(n, Path(tmp))
            runs = []
            for _ in range(args.repeats):
                p = subprocess.run(
                    [sys.executable, __file__, "--child", str(f)] + (["--no-box"] if args.no_box else []),
                    check=True,
                    capture_output=True,
                    text=True,
                    env=env,
                )
                runs.append(json.loads(p.stdout.strip().splitlines()[-1]))
            st = {s: (median([r[s][0] for r in runs]), median([r[s][1] for r in runs])) for s in STAGES if s in runs[0]}
            total = median([sum(r[s][0] for s in STAGES if s in r) for r in runs])
            peak = median([r["maxrss_mb"] for r in runs])
            rows.append((n, st, total, peak))
            print(
                f"{n:>9} {f.stat().st_size / 1e6:>8.1f} "
                + " ".join(f"{st[s][0]:>9.2f} {st[s][1]:>9.2f}" if s in st else f"{'-':>9} {'-':>9}" for s in STAGES)
                + f" {total:>8.2f} {peak:>8.0f}  {runs[0]['method']}",
                flush=True,
            )
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
