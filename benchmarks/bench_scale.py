"""How denavit's batch kernels scale with N, and the kernel rows of the speed issue's table, beside pinocchio
(and roboticstoolbox when installed). A script that prints tables, not a timed test.

    python benchmarks/bench_scale.py [--quick] [--max-n 10000000] [--max-bytes 2.5e9] [--json out.json]

Scale table: batch FK (into a reused `out=`), batch Jacobian (local_world_aligned, `out=`) and batch RNE (`out=`)
of the KR5 for N = 10^3 .. 10^7 (each size only while its arrays fit in --max-bytes), median wall time over
repeats on the default threads, then the median CPU time of the process with threads=1 (on a shared,
loaded machine the wall time also counts the waits for a core), and the growth exponent: the slope of log t
against log N fitted over N >= 10^4 (1.0 = linear).
Kernel rows: batch FK 100,000 on one core (threads=1; wall and process CPU time) and on two (threads=2), batch
Jacobian 100,000, FK 10^7 with out=, a single FK call from Python next to the binding's floor (an empty call: the
`Model.nq` getter), and
IK with one attempt (success rate and median, from benchmarks/bench_kinematics.py). pinocchio has no batch API:
its column is a Python loop over its C++ calls (pin.forwardKinematics / computeJointJacobians / rnea) on the
same chain, timed on fewer configurations and scaled per configuration.

The machine: the issue set its kernel targets on a 3.6 GHz AVX-512 CPU from that CPU's floors ("1.5x the compute
floor" at a measured 57 GFLOP/s). This script measures the same floor here, one core's double-precision peak as
OpenBLAS's DGEMM reaches it (the best of several 1500 x 1500 products; one BLAS thread), and copy bandwidth, and
prints each compute-bound target also scaled to this machine (target x 57 / this GFLOP/s) beside the issue's own.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from bench_kinematics import (  # noqa: E402
    ik_one_attempt,
    once,
    per_call,
    pin,
    pin_model_with_tool,
    rtb,
    rtb_robot_with_limits,
)

import denavit as dv  # noqa: E402

G = np.array([0.0, 0.0, -9.81])
ISSUE_GFLOPS = 57.0  # the speed issue's machine: measured double-precision peak of one core


def machine_floor(rep):
    """One core's double-precision GFLOP/s (best DGEMM of `rep` runs, thread CPU) and copy GB/s (read + write)."""
    rng = np.random.default_rng(1)
    a, b = rng.random((1500, 1500)), rng.random((1500, 1500))
    c = np.empty_like(a)
    x = rng.random(2**25)
    y = np.empty_like(x)

    def best(fn, clock):
        fn()
        return min(-clock() + (fn(), clock())[1] for _ in range(rep))

    gflops = 2 * 1500**3 / best(lambda: np.matmul(a, b, out=c), time.thread_time) / 1e9
    gbs = 2 * x.nbytes / best(lambda: np.copyto(y, x), time.perf_counter) / 1e9
    return gflops, gbs


def growth(ns, ts):
    """Slope of log t against log N over N >= 10^4 (all sizes when fewer than two qualify)."""
    ns, ts = np.asarray(ns, float), np.asarray(ts, float)
    keep = ns >= 1e4 if (ns >= 1e4).sum() >= 2 else np.ones(len(ns), bool)
    return float(np.polyfit(np.log(ns[keep]), np.log(ts[keep]), 1)[0]) if keep.sum() >= 2 else float("nan")


def fmt(s):
    return f"{s * 1e3:.3f} ms" if s >= 1e-3 else f"{s * 1e6:.2f} us"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats, N up to 10^6 (a smoke run)")
    ap.add_argument("--max-n", type=float, default=1e7, help="largest N of the scale table")
    ap.add_argument("--max-bytes", type=float, default=2.5e9, help="skip a size whose arrays exceed this")
    ap.add_argument("--json", help="also write the figures to this JSON file")
    args = ap.parse_args()
    rep = 3 if args.quick else 7
    max_n = min(args.max_n, 1e6) if args.quick else args.max_n
    m = dv.load_model("kr5")
    n = m.nq
    rng = np.random.default_rng(0)
    fig = {"scale": {}, "rows": {}}

    # --- scale table ---------------------------------------------------------------------------------------
    sizes = [int(10**k) for k in range(3, 8) if 10**k <= max_n]
    mi = m.with_inertias(np.linspace(4, 1, n), rng.uniform(-0.1, 0.1, (n, 3)), np.tile(np.eye(3) * 0.05, (n, 1, 1)))
    kernels = {
        "fk_batch (out=)": (
            16,
            lambda qs, out, th: dv.fk_batch(m, qs, out=out, threads=th),
            lambda N: np.empty((N, 4, 4)),
        ),
        "jacobian_batch (out=)": (
            6 * n,
            lambda qs, out, th: dv.jacobian_batch(m, qs, out=out, threads=th),
            lambda N: np.empty((N, 6, n)),
        ),
        "rnea_batch (out=)": (
            n,
            lambda qs, out, th: dv.rnea_batch(mi, qs, qs, qs, out=out, threads=th),
            lambda N: np.empty((N, n)),
        ),
    }
    gflops, gbs = machine_floor(rep)
    scale = ISSUE_GFLOPS / gflops
    print(
        f"denavit {dv.__version__}; {os.cpu_count()} cores; KR5; medians of {rep} runs; load average"
        f" {os.getloadavg()[0]:.1f}"
    )
    print(
        f"this machine, one core: {gflops:.1f} GFLOP/s (DGEMM), {gbs:.1f} GB/s (copy); the issue's: {ISSUE_GFLOPS:.0f}"
        f" GFLOP/s, 23-35 GB/s; compute-bound targets scaled by {scale:.2f}"
    )
    fig["machine"] = {"gflops": gflops, "copy_gbs": gbs, "target_scale": scale}

    def target(seconds):
        return f"<= {fmt(seconds)} (here: {fmt(seconds * scale)})"

    for label, threads, clock in (
        ("wall time, threads = default (RAYON_NUM_THREADS or every core)", None, time.perf_counter),
        (
            (
                "CPU time of the process, threads=1 (leaves out waiting for a core on a loaded machine; a long call"
                " runs on a helper thread that Ctrl-C can stop, so the calling thread alone would miss it)"
            ),
            1,
            time.process_time,
        ),
    ):
        print()
        print(label)
        print(
            "| kernel | " + " | ".join(f"N = 10^{len(str(N)) - 1}" for N in sizes) + " | growth exponent (N >= 10^4) |"
        )
        print("|---|" + "---|" * len(sizes) + "---|")
        for name, (per_row, run, alloc) in kernels.items():
            ns, ts = [], []
            for N in sizes:
                if 8 * N * (n + per_row) > args.max_bytes:
                    break
                qs = rng.uniform(-np.pi, np.pi, (N, n))
                out = alloc(N)
                ts.append(
                    once(
                        lambda qs=qs, out=out, run=run, th=threads: run(qs, out, th),
                        rep if N < 10**7 else max(3, rep // 2),
                        clock,
                    )
                )
                ns.append(N)
                del qs, out
            cells = [fmt(t) for t in ts] + ["(memory)"] * (len(sizes) - len(ts))
            fig["scale"][f"{name}, threads={threads}"] = {"n": ns, "t": ts, "growth": growth(ns, ts)}
            print(f"| {name} | " + " | ".join(cells) + f" | {growth(ns, ts):.3f} |")

    # --- the speed issue's kernel rows -----------------------------------------------------------------------
    rows = []  # (case, denavit, pinocchio, rtb, target)
    N = 100_000
    qs = rng.uniform(-np.pi, np.pi, (N, n))
    out = np.empty((N, 4, 4))
    t1 = once(lambda: dv.fk_batch(m, qs, out=out, threads=1), rep * 3)
    c1 = once(lambda: dv.fk_batch(m, qs, out=out, threads=1), rep * 3, time.process_time)
    t2 = once(lambda: dv.fk_batch(m, qs, out=out, threads=2), rep * 3)
    tf = once(lambda: dv.fk_batch(m, qs, threads=1), rep * 3)
    cf = once(lambda: dv.fk_batch(m, qs, threads=1), rep * 3, time.process_time)
    p_fk = p_j = p_r = r_fk = "-"
    if pin is not None:
        pm, pd, _ = pin_model_with_tool(m)
        k = 5000
        p_fk = (
            fmt(once(lambda: [pin.forwardKinematics(pm, pd, q) for q in qs[:k] + m.offsets], rep) * N / k)
            + " (Python loop, scaled)"
        )
        p_j = (
            fmt(once(lambda: [pin.computeJointJacobians(pm, pd, q) for q in qs[:k] + m.offsets], rep) * N / k)
            + " (Python loop, scaled)"
        )
        p_r = fmt(once(lambda: [pin.rnea(pm, pd, q, q, q) for q in qs[:k]], rep) * N / k) + " (Python loop, scaled)"
    if rtb is not None:
        ets = rtb_robot_with_limits(m).ets()
        r_fk = fmt(once(lambda: ets.fkine(qs), max(3, rep // 2)))
    rows.append(
        (
            f"batch FK {N:,} (KR5 -> (N, 4, 4), out=), one core: wall (process CPU)",
            f"{fmt(t1)} ({fmt(c1)})",
            p_fk,
            r_fk,
            target(1.8e-3),
        )
    )
    rows.append((f"batch FK {N:,}, out=, two cores (threads=2)", fmt(t2), "-", "-", target(1.0e-3)))
    rows.append(
        (f"batch FK {N:,}, one core, a fresh result array: wall (process CPU)", f"{fmt(tf)} ({fmt(cf)})", "-", "-", "-")
    )
    # out= one value off numpy's 16-byte alignment: the kernel's plain stores instead of streaming ones (docs/speed.md)
    plain = np.empty(N * 16 + 1)[1:].reshape(N, 4, 4)
    cp = once(lambda: dv.fk_batch(m, qs, out=plain, threads=1), rep * 3, time.process_time)
    rows.append(
        (
            f"batch FK {N:,}, one core (process CPU), plain stores (out= a view one value off the alignment)",
            fmt(cp),
            "-",
            "-",
            "-",
        )
    )
    oj = np.empty((N, 6, n))
    tj = once(lambda: dv.jacobian_batch(m, qs, out=oj), rep * 3)
    tj1 = once(lambda: dv.jacobian_batch(m, qs, out=oj, threads=1), rep * 3)
    cj1 = once(lambda: dv.jacobian_batch(m, qs, out=oj, threads=1), rep * 3, time.process_time)
    rows.append(
        (
            f"batch Jacobian {N:,} (local_world_aligned, out=), default threads / one core (process CPU)",
            f"{fmt(tj)} / {fmt(tj1)} ({fmt(cj1)})",
            p_j,
            "-",
            target(5e-3),
        )
    )
    orn = np.empty((N, n))
    tr = once(lambda: dv.rnea_batch(mi, qs, qs, qs, out=orn), rep * 3)
    rows.append((f"batch RNE {N:,} (out=)", fmt(tr), p_r, "-", "-"))
    big = 10**7
    if 8 * big * (n + 16) <= args.max_bytes and not args.quick:
        qb = rng.uniform(-np.pi, np.pi, (big, n))
        ob = np.empty((big, 4, 4))
        tb = once(lambda: dv.fk_batch(m, qb, out=ob), 3)
        cb = once(lambda: dv.fk_batch(m, qb, out=ob, threads=1), 3, time.process_time)
        rows.append(
            (
                "batch FK 10^7 with out= (default threads); one core's process CPU",
                f"{fmt(tb)}; {fmt(cb)}",
                "-",
                "-",
                target(0.25),
            )
        )
        del qb, ob
    q = np.array([0.3, -0.2, 0.5, 0.1, 0.4, -0.3])
    number = 2000 if args.quick else 20000
    t_fk = per_call(lambda: dv.fk(m, q), number, rep)
    t_empty = per_call(lambda: m.nq, number, rep)
    c_fk = per_call(lambda: dv.fk(m, q), number, rep, time.thread_time)
    p_one = "-"
    if pin is not None:
        p_one = (
            fmt(per_call(lambda: pin.forwardKinematics(pm, pd, q), number, rep))
            + " (forwardKinematics, no array returned)"
        )
    rows.append(
        (
            (
                "single FK from Python (returns the 4x4 array), wall (thread CPU); the binding's floor (an empty call,"
                " Model.nq)"
            ),
            f"{fmt(t_fk)} ({fmt(c_fk)}); floor {fmt(t_empty)}",
            p_one,
            "-",
            "<= 0.25 us",
        )
    )
    q1, o1 = q[None], np.empty((1, 4, 4))
    t_b1 = per_call(lambda: dv.fk_batch(m, q1, out=o1, threads=1), number // 4, rep)
    t_bd = per_call(lambda: dv.fk_batch(m, q1, out=o1), number // 4, rep)
    rows.append(
        (
            "batch FK of one configuration (a batch call's own cost), threads=1 / default",
            f"{fmt(t_b1)} / {fmt(t_bd)}",
            "-",
            "-",
            "-",
        )
    )
    one = ik_one_attempt(
        [(name, dv.load_model(name)) for name in ("kr5", "ur5", "puma560")],
        100 if args.quick else 300,
        rtb is not None,
        pin is not None,
    )
    for r in one:  # (robot, newton, lm, [rtb ik_NR, rtb ik_LM,] pinocchio): rtb's cells only when it is installed
        rtb_cell = f"{r[3]} / {r[4]}" if rtb is not None else "-"
        rows.append(
            (
                f"IK one attempt, {r[0]}: newton / lm (success, median)",
                f"{r[1]} / {r[2]}",
                r[-1],
                rtb_cell,
                ">= 97 %, <= 5 us",
            )
        )

    print()
    print(
        "| case | denavit | pinocchio"
        + ("" if pin is not None else " (not installed)")
        + " | roboticstoolbox"
        + ("" if rtb is not None else " (not installed)")
        + " | target |"
    )
    print("|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
        fig["rows"][r[0]] = r[1]
    if args.json:
        with open(args.json, "w") as f:
            json.dump(fig, f, indent=2)


if __name__ == "__main__":
    main()
