"""Compensation end to end: how much more accurate the robot becomes, and what the covariance predicts.

A "true" robot: the KR5 (Hayat Table III) with every DH parameter off by a random 0.5 mm / 0.05 deg
(fixed seed), whose controller's joint readings carry errors: scale errors of 2e-4 on joints 2 and 3 (as
seen on real arms, ../shared/ANCHORS.md) and white noise (default 10 arcsec). Two routes identify it:
- identify: the paper's 30 degree protocol (Table II), 0.02 mm tracker noise, the default method (the
  global fit with the readings) and the points-only geometric circle fits, ED-H; and a longer protocol (the
  90 degree ranges, 100 points per sweep);
- calibrate: 100 quasi-random poses, 0.02 mm tracker noise, the readings, ED-H least squares with a scale
  parameter per joint.
Then 1,000 random reachable targets (tool poses of random configurations, nominal joint values known, as
an offline-programmed job) are compensated with each identified model, the joint values turned into readings
through the route's estimated reading scales (calibrate's ``scales``; identify's where auto fitted them); a
controller that keeps the nominal model turns each command into readings (its own IK from the program's
configuration), and the true robot's joints turn by those readings times (1 + scale). Printed: tool-position error RMS / max before (nominal commands) and after,
next to the RMS the identified covariance predicts, the flagged rows, and the time per target beside
``ik_batch``. Targets: after <= 0.05 mm RMS and within 1.5x of the prediction.

Run: ``python benchmarks/bench_compensate.py [--targets 1000] [--seed 1]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import denavit as dv
from denavit import calibration as cal
from denavit import compensation as cp
from denavit import sweeps as sw

ARCSEC = np.radians(1 / 3600)


ARC_005 = np.radians(0.05)  # 0.05 deg


def perturbed(robot, rng, length=0.5e-3, angle=ARC_005):
    t = robot.table
    E = rng.uniform(-1, 1, t.params.shape) * np.where(np.array(t.angle_columns), angle, length)
    return dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model("true", robot.names, robot.lower, robot.upper)


def median_time(f, repeats=5):
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--targets", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise-mm", type=float, default=0.02)
    ap.add_argument("--reading-arcsec", type=float, default=10.0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    kr5 = dv.load_robot("kr5")
    tool = np.eye(4)
    tool[:3, 3] = [0.05, 0.03, 0.10]
    nominal = kr5.model().with_tool(tool)
    true = perturbed(kr5, rng).with_tool(tool)
    noise, qnoise = args.noise_mm * 1e-3, args.reading_arcsec * ARCSEC
    scale = np.array([0, 2e-4, -2e-4, 0, 0, 0])  # reading = true joint value / (1 + scale)

    def readings(q_true):
        return q_true / (1 + scale) + rng.normal(0, qnoise, q_true.shape)

    # route 1: circle-point identification, the paper's 30 degree protocol
    home = np.radians(sw.PAPER_HOME_DEG)
    sweeps = sw.simulate(true, home=home, ranges=np.radians(sw.PAPER_RANGES_DEG[30]), points_per_sweep=30, tool_point=tool[:3, 3], noise=noise, seed=args.seed)
    sweeps = sw.SweepSet([sw.Sweep(s.joint, s.points, readings(s.q), s.where) for s in sweeps.sweeps], 6, sweeps.home, sweeps.kinds, sweeps.source, sweeps.units)
    idr = dv.identify(sweeps, convention="edh", nominal=kr5)
    idg = dv.identify(sweeps, method="geometric", convention="edh", nominal=kr5)
    long = sw.simulate(true, home=home, ranges=np.radians(sw.PAPER_RANGES_DEG[90]), points_per_sweep=100, tool_point=tool[:3, 3], noise=noise, seed=args.seed)
    long = sw.SweepSet([sw.Sweep(s.joint, s.points, readings(s.q), s.where) for s in long.sweeps], 6, long.home, long.kinds, long.source, long.units)
    idl = dv.identify(long, convention="edh", nominal=kr5)
    # route 2: calibration from 100 poses with noisy readings
    q = cal.configurations(kr5, 100)
    meas = cal.simulate(true, q, tool=tool[:3, 3], noise=noise, seed=args.seed)
    meas = cal.Measurements(readings(q), meas.points, None, "simulated, readings with errors")
    car = cal.calibrate(meas, kr5, tool=tool[:3, 3], scale=True)
    identified_2 = car.model()

    # the job: random reachable targets with their nominal joint values
    Q = rng.uniform(kr5.lower, kr5.upper, (args.targets, 6)) * 0.9
    T = dv.fk_batch(nominal, Q)
    print(f"KR5 with 0.5 mm / 0.05 deg errors per DH parameter, reading scale errors 2e-4 (J2, J3) and {args.reading_arcsec:g} arcsec noise, {args.noise_mm} mm tracker noise; "
          f"{args.targets} targets")
    print(f"{'route':<34} {'flagged':>7} {'before RMS':>11} {'before max':>11} {'after RMS':>10} {'after max':>10} {'predicted':>10} {'ratio':>6} {'us/target':>10}")
    def id_scales(r):
        return np.array([f.scale - 1 if np.isfinite(f.scale_sigma) else 0.0 for f in r.fits])

    routes = [(f"identify ({p} deg, {r.method}, ED-H)", r.model(convention="edh"), r, id_scales(r)) for p, r in ((30, idr), (30, idg), (90, idl))]
    routes.append(("calibrate (100 poses, ED-H)", identified_2, car, np.array([car.scales.get(f"scale_{j + 1}", 0.0) for j in range(6)])))

    def executed(q_read):
        """The true robot's tool points when its controller holds readings q_read (its joints turn by q (1 + scale))."""
        return dv.fk_batch(true, q_read * (1 + scale))[:, :3, 3]

    for label, model, result, s_id in routes:
        res = cp.compensate(nominal, model, T, q_nominal=Q, result=result)
        commands = dv.fk_batch(nominal, res.q / (1 + s_id))  # the joint values as readings, through the estimated scales
        t_comp = median_time(lambda m=model: cp.compensate(nominal, m, T, q_nominal=Q))
        # the nominal controller: its own IK of each command from the program's configuration
        ctrl = dv.ik_batch(nominal, commands, Q, restarts=0)
        ok = res.ok & ctrl.success
        p_after = executed(ctrl.q)
        p_before = executed(Q)
        after = np.linalg.norm(p_after - T[:, :3, 3], axis=1)[ok]
        before = np.linalg.norm(p_before - T[:, :3, 3], axis=1)[ok]
        pred = float(np.sqrt(np.mean(res.predicted_after[ok] ** 2)))
        rms = float(np.sqrt(np.mean(after**2)))
        print(f"{label:<34} {int((~ok).sum()):>7d} {np.sqrt(np.mean(before ** 2)) * 1e3:>8.4f} mm {before.max() * 1e3:>8.4f} mm "
              f"{rms * 1e3:>7.4f} mm {after.max() * 1e3:>7.4f} mm {pred * 1e3:>7.4f} mm {rms / pred:>6.2f} {t_comp / args.targets * 1e6:>10.2f}")
    t_ik = median_time(lambda: dv.ik_batch(identified_2, T, Q))
    print(f"{'ik_batch (identified, from the program)':<34} {'':>7} {'':>11} {'':>11} {'':>10} {'':>10} {'':>10} {'':>6} {t_ik / args.targets * 1e6:>10.2f}")
    print("targets: after <= 0.05 mm RMS; after / predicted <= 1.5")


if __name__ == "__main__":
    main()
