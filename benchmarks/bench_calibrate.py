"""Whole-model calibration (denavit.calibration): speed, statistics against the Cramér-Rao bound, and accuracy
beside the per-circle identification methods (denavit.identify) on Hayat et al.'s protocols.

Tables printed:

1. Time of ``calibrate`` for a 6R arm (KR5, ED-H, 27 identifiable parameters) from N random poses (0.02 mm
   noise), median over repeats, with the time of the Rust identification Jacobian alone.
1b. Scale: wall and CPU time of ``calibrate`` from 10^3 to 5 x 10^4 poses (issue 18: 50,000 poses in <= 1.5 s,
   growth <= 1.05 per decade) with the growth exponent per step, and ``plan`` selecting 50 of 10^4 and 10^5
   candidate poses (greedy D-optimal; issue 18: <= 3 s at 10^5).
2. Monte Carlo statistics (random poses and the 30 degree sweep protocol): RMS error / Cramér-Rao bound per
   parameter, reported sigma / Monte Carlo spread, planned sigma / spread (median, min, max over parameters).
3. Per protocol (90 and 30 degrees, 30 points per sweep): RMS axis-position error per joint (distance of the
   true circle centre from the identified axis) of every per-circle method of ``denavit.identify.identify``, of
   its global fit, and of ``calibrate``, beside the bound of the plan; and the RMS tool-position error of each
   identified model over 1,000 random configurations; for comparison, the same truth calibrated from 100
   random poses spread over the joint limits (not sweeps) with the same noise.

Run ``python benchmarks/bench_calibrate.py`` (``--runs`` Monte Carlo runs, ``--quick`` for a short run).
The truth is the KR5 of Hayat et al. Table III with every identifiable ED-H parameter moved by 0.5 mm / 1 mrad
(seeded), seen from a measurement frame equal to its base frame.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import denavit as dv
from denavit import calibration as cal
from denavit import sweeps as sw
from denavit.calibration.least_squares import covariance, residuals, weights

NOISE = 2e-5
TOOL = np.array([0.05, 0.03, 0.10])
HOME = np.radians(sw.PAPER_HOME_DEG)
METHODS = ["kasa", "hyper", "geometric", "readings", "global"]


def truth_of(kr5, names, seed=11):
    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    rng = np.random.default_rng(seed)
    x = pz.x0.copy()
    for n in names:
        c = pz.index(n)
        x[c] += rng.normal(0, 5e-4 if pz.units[c] == "length" else 1e-3)
    return pz, x, pz.model(x, "truth"), x[[pz.index(n) for n in ("tool_x", "tool_y", "tool_z")]]


def median_time(f, repeats):
    f()
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return float(np.median(t)), float(np.min(t))


def table_time(kr5, repeats):
    print("\n1. Time of calibrate (KR5, ED-H, points, 0.02 mm noise; median / min over repeats)")
    print(
        f"{'poses':>6} {'calibrate [ms]':>15} {'min [ms]':>9} {'+ holdout 0.2 [ms]':>19} {'Jacobian [us]':>14}"
        f" {'evaluations':>12} {'rank':>5}"
    )
    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    for n in (50, 100, 200, 500):
        q = cal.configurations(kr5, n, skip=17)
        meas = cal.simulate(kr5, q, tool=TOOL, noise=NOISE)
        med, mn = median_time(lambda meas=meas: cal.calibrate(meas, kr5, tool=TOOL), repeats)
        medh, _ = median_time(lambda meas=meas: cal.calibrate(meas, kr5, tool=TOOL, holdout=0.2), repeats)
        jac, _ = median_time(lambda q=q: pz.evaluate(pz.x0, q), repeats * 5)
        res = cal.calibrate(meas, kr5, tool=TOOL)
        flag = "  <- 6R from 100 poses" if n == 100 else ""
        print(
            f"{n:>6} {med * 1e3:>15.1f} {mn * 1e3:>9.1f} {medh * 1e3:>19.1f} {jac * 1e6:>14.0f} {res.evaluations:>12}"
            f" {res.identifiability.rank:>5}{flag}"
        )


def table_scale(kr5, repeats):
    print(
        "\n1b. Scale of calibrate and of plan --select (KR5, ED-H, points; median over repeats; run with"
        " OPENBLAS_NUM_THREADS=1 on a loaded machine)"
    )
    print(f"{'case':<34} {'wall [s]':>9} {'cpu [s]':>9} {'growth (cpu)':>13} {'over a decade':>14}")

    def cpu_time(f):
        w, c = [], []
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            f()
            w.append(time.perf_counter() - t0)
            c.append(time.process_time() - c0)
        return float(np.median(w)), float(np.median(c))

    prev, seen = None, {}
    for n in (1_000, 5_000, 10_000, 50_000):
        q = cal.configurations(kr5, n, skip=17)
        meas = cal.simulate(kr5, q, tool=TOOL, noise=NOISE)
        cal.calibrate(meas, kr5, tool=TOOL)
        w, c = cpu_time(lambda meas=meas: cal.calibrate(meas, kr5, tool=TOOL))
        growth = f"{np.log(c / prev[1]) / np.log(n / prev[0]):13.2f}" if prev else f"{'':>13}"
        # the exponent from the size ten times smaller (the "growth per decade")
        decade = f"{np.log10(c / seen[n // 10]):14.2f}" if n // 10 in seen else f"{'':>14}"
        print(f"{f'calibrate, {n} poses':<34} {w:9.3f} {c:9.3f} {growth} {decade}", flush=True)
        prev, seen[n] = (n, c), c
    for n in (10_000, 100_000):
        q = cal.configurations(kr5, n)
        w, c = cpu_time(lambda q=q: cal.plan(kr5, q=q, select=50, noise=NOISE, tool=TOOL))
        print(f"{f'plan, select 50 of {n} candidates':<34} {w:9.3f} {c:9.3f}", flush=True)


def table_statistics(kr5, runs):
    print(f"\n2. Monte Carlo against the Cramér-Rao bound ({runs} runs, 0.02 mm noise)")
    print(
        f"{'data':<22} {'free':>5} {'RMSE/CRB med':>13} {'max':>6} {'pooled':>7} {'sigma/spread med':>17} {'min':>6}"
        f" {'max':>6} {'plan/spread med':>16} {'min':>6} {'max':>6} {'ms/run':>7}"
    )
    for data in ("100 random poses", "30 deg sweeps"):
        if data.startswith("100"):
            q = cal.configurations(kr5, 100, skip=50)
            pl = cal.plan(kr5, q=q, noise=NOISE, tool=TOOL)
        else:
            prot = cal.Protocol.paper(30, points_per_sweep=30, tool_point=TOOL)
            q = prot.configurations()
            pl = cal.plan(kr5, prot, noise=NOISE)
        pz, x, truth, tool = truth_of(kr5, pl.free_names)
        idx = [pz.index(n) for n in pl.free_names]
        w = weights("point", NOISE, NOISE)
        _, J, _ = residuals(pz, x, cal.Measurements(q, np.zeros((len(q), 3))), w)
        crb = np.sqrt(np.diag(covariance(J[:, idx], 1.0)))
        est, sig = [], []
        t0 = time.perf_counter()
        for run in range(runs):
            if data.startswith("100"):
                meas = cal.simulate(truth, q, tool=tool, noise=NOISE, seed=run)
            else:
                meas = sw.simulate(
                    truth,
                    home=HOME,
                    ranges=np.radians(sw.PAPER_RANGES_DEG[30]),
                    points_per_sweep=30,
                    tool_point=tool,
                    noise=NOISE,
                    seed=run,
                )
            res = cal.calibrate(meas, kr5, tool=TOOL)
            est.append(res.values[idx])
            sig.append(res.sigma[idx])
        dt = (time.perf_counter() - t0) / runs
        est, sig = np.array(est), np.array(sig)
        err = est - x[idx]
        r1 = np.sqrt(np.mean(err**2, axis=0)) / crb
        pooled = np.sqrt(np.mean((err / crb) ** 2))
        spread = est.std(axis=0, ddof=1)
        r2 = sig.mean(axis=0) / spread
        r3 = pl.sigma[idx] / spread
        print(
            f"{data:<22} {len(idx):>5} {np.median(r1):>13.3f} {r1.max():>6.3f} {pooled:>7.3f} {np.median(r2):>17.3f}"
            f" {r2.min():>6.3f} {r2.max():>6.3f} {np.median(r3):>16.3f} {r3.min():>6.3f} {r3.max():>6.3f}"
            f" {dt * 1e3:>7.1f}"
        )


def line_errors(c_true, points, directions):
    r = c_true - points
    return np.linalg.norm(r - directions * np.sum(r * directions, axis=1)[:, None], axis=1)


def table_accuracy(kr5, runs, protocols):
    kr5_plan = cal.plan(kr5, cal.Protocol.paper(30), noise=NOISE)
    pz, x, truth, tool = truth_of(kr5, kr5_plan.free_names)
    T = np.eye(4)
    T[:3, 3] = tool
    p_home = dv.fk(truth.with_tool(T), HOME)[:3, 3]
    c_true, _ = cal.axis_lines(truth, HOME, p_home)
    qs = np.random.default_rng(99).uniform(truth.lower, truth.upper, (1000, 6))
    p_true = dv.fk_batch(truth.with_tool(T), qs)[:, :3, 3]
    for protocol in protocols:
        prot = cal.Protocol.paper(protocol, points_per_sweep=30, tool_point=TOOL)
        pl = cal.plan(kr5, prot, noise=NOISE)
        print(
            f"\n3. Paper protocol {protocol} deg (Hayat Table II), 30 points per sweep, {runs} runs: RMS axis-position"
            " error per joint [um], tool-position RMS over 1,000 configurations [um], time per call [ms]"
        )
        print(f"{'method':<24}" + "".join(f"{'A' + str(j + 1):>8}" for j in range(6)) + f"{'tool':>9}{'ms':>8}")
        rows = {m: ([], [], 0.0) for m in [*METHODS, "calibrate (edh)", "calibrate, 100 poses"]}
        q_random = cal.configurations(kr5, 100, skip=50)
        for run in range(runs):
            s = sw.simulate(
                truth,
                home=HOME,
                ranges=prot.ranges,
                points_per_sweep=30,
                tool_point=tool,
                noise=NOISE,
                seed=1000 * protocol + run,
            )
            for m in rows:
                t0 = time.perf_counter()
                if m.startswith("calibrate"):
                    data = (
                        s
                        if m == "calibrate (edh)"
                        else cal.simulate(truth, q_random, tool=tool, noise=NOISE, seed=1000 * protocol + run)
                    )
                    res = cal.calibrate(data, kr5, tool=TOOL)
                    model = res.model()
                    dt = time.perf_counter() - t0
                    c, z = cal.axis_lines(model, HOME, p_home)
                    pt = dv.fk_batch(model, qs)[:, :3, 3]
                else:
                    res = dv.identify(s, method=m, nominal=kr5, convention="edh")
                    dt = time.perf_counter() - t0
                    c, z = np.array(res.axes.points), np.array(res.axes.directions)
                    pt = dv.fk_batch(res.model(), qs)[:, :3, 3]
                e, tl, tt = rows[m]
                e.append(line_errors(c_true, c, z))
                tl.append(np.sqrt(np.mean(np.sum((pt - p_true) ** 2, axis=1))))
                rows[m] = (e, tl, tt + dt)
        for m, (e, tl, tt) in rows.items():
            rms = np.sqrt(np.mean(np.square(e), axis=0)) * 1e6
            print(
                f"{m:<24}"
                + "".join(f"{v:>8.2f}" for v in rms)
                + f"{np.sqrt(np.mean(np.square(tl))) * 1e6:>9.2f}{tt / runs * 1e3:>8.1f}"
            )
        print(f"{'bound (plan, joint fit)':<24}" + "".join(f"{v * 1e6:>8.2f}" for v in pl.axis_sigma[:, 0]))
        print(f"{'bound (plan, per circle)':<24}" + "".join(f"{v * 1e6:>8.2f}" for v in pl.per_circle_sigma[:, 0]))
        print(f"{'bound ratio':<24}" + "".join(f"{v:>8.2f}" for v in pl.per_circle_sigma[:, 0] / pl.axis_sigma[:, 0]))
        b = pl.box
        print(
            f"measuring volume (plan): {b.lengths[0] * 1e3:.0f} x {b.lengths[1] * 1e3:.0f} x {b.lengths[2] * 1e3:.0f}"
            f" mm, {b.volume:.4f} m^3"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=100, help="Monte Carlo runs of table 2")
    ap.add_argument(
        "--accuracy-runs", type=int, default=10, help="runs per protocol of table 3 (identify takes ~0.5 s a call)"
    )
    ap.add_argument("--repeats", type=int, default=30, help="timing repeats of table 1")
    ap.add_argument("--protocols", default="30,90")
    ap.add_argument("--quick", action="store_true", help="runs 20, accuracy runs 3, repeats 10")
    ap.add_argument("--scale-only", action="store_true", help="only the scale table (1b)")
    args = ap.parse_args()
    if args.quick:
        args.runs, args.accuracy_runs, args.repeats = 20, 3, 10
    kr5 = dv.load_robot("kr5")
    print(
        f"denavit {dv.__version__}: whole-model calibration benchmark (KR5, Hayat et al. Table III; noise {NOISE * 1e3}"
        " mm per coordinate)"
    )
    if args.scale_only:
        table_scale(kr5, 3)
        return
    table_time(kr5, args.repeats)
    table_scale(kr5, 3)
    table_statistics(kr5, args.runs)
    table_accuracy(kr5, args.accuracy_runs, [int(p) for p in args.protocols.split(",")])


if __name__ == "__main__":
    main()
