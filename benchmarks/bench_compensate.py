"""Compensation end to end: how much more accurate the robot becomes, and what the covariance predicts.

A "true" robot: the KR5 (Hayat Table III) with every DH parameter off by a random 0.5 mm / 0.05 deg
(fixed seed), whose controller's joint readings carry errors: scale errors of 2e-4 on joints 2 and 3 (as
seen on real arms, ../shared/ANCHORS.md: the joint turns 1 + scale times its reading) and white reading noise
(default 10 arcsec). The controller commands readings; the joints turn by the readings times (1 + scale).
Two routes identify it:
- identify: the paper's protocols (Table II: the 30 degree ranges, and the 90 degree ones) about the paper's
  home, recorded as a laser tracker streams them: a point every 1 / rate while the joint turns at a constant
  speed (default 1 deg/s), 0.02 mm tracker noise, every joint's readings recorded (with their noise); the
  default method (auto: the global fit with the readings, the readings' scale errors joint by joint where the
  BIC supports them) and, for comparison, the
  points-only geometric circle fits; ED-H. The default rate is 1 kHz (``--rate-hz``): laser trackers stream at
  up to 1 kHz and controllers log their readings at 250 Hz-1 kHz, 1e5 points per sweep being normal (issue 12);
  a 30 degree sweep at 1 deg/s is then 30,000 points. The 30 degree protocol is also run at ``--also-rate-hz``
  (default 100 Hz, 3,000 points per sweep: a slower tracker, or a sweep ten times as fast; 0 skips it); the 90
  degree protocol (``--protocols 30,90``; 90,000 points per sweep at 1 kHz, minutes) only when asked for;
- calibrate: 100 quasi-random poses, 0.02 mm tracker noise, the readings, ED-H least squares with a scale
  parameter per joint.
Then 1,000 random reachable positions (tool poses of random configurations, nominal joint values known, as
an offline-programmed job) are compensated with each result (``compensate(nominal, result, ...)``: its model,
and its reading model: the scales it estimated, about the sweeps' home for identify, about zero for
calibrate); a controller that keeps the nominal model turns each command into readings (its own IK from the
program's configuration), and the true robot's joints turn by those readings times (1 + scale). Printed:
tool-position error RMS / max before (nominal commands) and after, next to the RMS the result's covariance
predicts (its parameters and reading scales), the flagged rows, and the time per position beside ``ik_batch``.
Aims: after <= 0.05 mm RMS and within 1.5x of the prediction.

Run: ``python benchmarks/bench_compensate.py [--positions 1000] [--seed 1] [--rate-hz 1000] [--also-rate-hz 100]
[--protocols 30,90] [--speed-deg-s 1]``.
"""

from __future__ import annotations

import argparse
import math
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
    return dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model(
        "true", robot.names, robot.lower, robot.upper
    )


def median_time(f, repeats=5):
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def recorded(true, scale, ranges, home, rate, speed, noise, qnoise, rng) -> sw.SweepSet:
    """The sweeps of ``true`` over ``ranges`` (rad) about ``home`` (readings, rad) as a tracker at ``rate`` (Hz)
    records them while the controller turns each joint at ``speed`` (rad/s): the joints at readings x (1 + scale),
    tracker noise ``noise`` (m), every reading recorded with white noise ``qnoise`` (rad)."""
    flange = true.with_tool(np.eye(4))
    tool = np.asarray(true.T_flange_tool)[:3, 3]
    out = []
    for j in range(6):
        m = max(int(round(abs(ranges[j][1] - ranges[j][0]) / speed * rate)), 3)
        r = np.tile(home, (m, 1))
        r[:, j] = np.linspace(ranges[j][0], ranges[j][1], m)
        T = dv.fk_batch(flange, r * (1 + scale))
        p = T[:, :3, :3] @ tool + T[:, :3, 3] + rng.normal(0, noise, (m, 3))
        out.append(sw.Sweep(j + 1, p, r + rng.normal(0, qnoise, r.shape), []))
    return sw.SweepSet(
        out,
        6,
        np.asarray(home, dtype=float),
        ["revolute"] * 6,
        "simulated tracker stream",
        {"length": "m", "angle": "rad"},
    )


TOOL = np.array([0.05, 0.03, 0.10])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--positions", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise-mm", type=float, default=0.02)
    ap.add_argument("--reading-arcsec", type=float, default=10.0)
    ap.add_argument(
        "--rate-hz", type=float, default=1000.0, help="tracker rate (points per second; trackers stream at up to 1 kHz)"
    )
    ap.add_argument(
        "--also-rate-hz", type=float, default=100.0, help="a second tracker rate for the 30 degree protocol (0: none)"
    )
    ap.add_argument(
        "--protocols", default="30", help="the paper's protocols identified (degrees, comma-separated: 30,90)"
    )
    ap.add_argument("--speed-deg-s", type=float, default=1.0, help="joint speed during a sweep")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    kr5 = dv.load_robot("kr5")
    tool = np.eye(4)
    tool[:3, 3] = TOOL
    nominal = kr5.model().with_tool(tool)
    true = perturbed(kr5, rng).with_tool(tool)
    noise, qnoise = args.noise_mm * 1e-3, args.reading_arcsec * ARCSEC
    scale = np.array([0, 2e-4, -2e-4, 0, 0, 0])  # the joint turns (1 + scale) times its reading

    def readings(q_true):
        return q_true / (1 + scale) + rng.normal(0, qnoise, q_true.shape)

    # route 1: circle-point identification, the paper's protocols streamed by a tracker
    home = np.radians(sw.PAPER_HOME_DEG)
    speed = np.radians(args.speed_deg_s)
    runs = []
    protocols = [int(p) for p in args.protocols.split(",")]
    for prot, rate in [(p, args.rate_hz) for p in protocols] + (
        [(30, args.also_rate_hz)] if args.also_rate_hz > 0 and 30 in protocols else []
    ):
        sweeps = recorded(true, scale, np.radians(sw.PAPER_RANGES_DEG[prot]), home, rate, speed, noise, qnoise, rng)
        pts = sum(len(s.points) for s in sweeps.sweeps)
        t0 = time.perf_counter()
        runs.append((prot, rate, pts, dv.identify(sweeps, convention="edh", nominal=kr5), time.perf_counter() - t0))
        if prot == 30 and rate == args.rate_hz:
            runs.append(
                (prot, rate, pts, dv.identify(sweeps, method="geometric", convention="edh", nominal=kr5), math.nan)
            )
    # route 2: calibration from 100 poses with noisy readings
    q = cal.configurations(kr5, 100)
    meas = cal.simulate(true, q, tool=TOOL, noise=noise, seed=args.seed)
    meas = cal.Measurements(readings(q), meas.points, None, "simulated, readings with errors")
    car = cal.calibrate(meas, kr5, tool=TOOL, scale=True)

    # the job: random reachable positions with their nominal joint values
    Q = rng.uniform(kr5.lower, kr5.upper, (args.positions, 6)) * 0.9
    T = dv.fk_batch(nominal, Q)
    print(
        "KR5 with 0.5 mm / 0.05 deg errors per DH parameter, reading scale errors 2e-4 (J2, J3) and"
        f" {args.reading_arcsec:g} arcsec noise, {args.noise_mm} mm tracker noise; sweeps at {args.speed_deg_s:g}"
        f" deg/s; {args.positions} positions"
    )
    for prot, rate, pts, r, dt in runs:
        if r.method != "geometric":
            if r.reading_scale is None:
                scales = "none fitted"
            else:  # the left-out scales (*): zero, their root-mean-square error from the covariance
                rms = np.sqrt(np.diag(r.axis_scale_cov)[-6:])
                scales = ", ".join(
                    f"J{j + 1} {v * 1e6:+.0f} +/- {e * 1e6:.0f}{'' if np.isfinite(f.scale_sigma) else '*'}"
                    for j, (v, e, f) in enumerate(zip(r.reading_scale, rms, r.fits))
                )
            print(
                f"  identify {prot} deg at {rate:g} Hz: {pts} points, {dt:.1f} s; {r.method}; reading scales (ppm; *"
                f" left out): {scales}"
            )
    print(f"  calibrate: scales (ppm) {', '.join(f'{k} {v * 1e6:+.0f}' for k, v in car.scales.items())}")
    print(
        f"{'route':<40} {'flagged':>7} {'before RMS':>11} {'before max':>11} {'after RMS':>10} {'after max':>10}"
        f" {'predicted':>10} {'ratio':>6} {'us/position':>12}"
    )
    routes = [(f"identify ({p} deg, {rate:g} Hz, {r.method})", r) for p, rate, _, r, _ in runs]
    routes.append(("calibrate (100 poses, ED-H)", car))

    def executed(q_read):
        """The true robot's tool points when its controller holds readings q_read (its joints turn by q (1 + scale))."""
        return dv.fk_batch(true, q_read * (1 + scale))[:, :3, 3]

    for label, result in routes:
        # the result's model and reading model (its reading scales): the commands are what a nominal controller needs
        res = cp.compensate(nominal, result, T, q_nominal=Q, result=result)
        t_comp = median_time(lambda r=result: cp.compensate(nominal, r, T, q_nominal=Q, predict=False))
        # the nominal controller: its own IK of each command from the program's configuration
        ctrl = dv.ik_batch(nominal, res.commands, Q, restarts=0)
        ok = res.ok & ctrl.success
        p_after = executed(ctrl.q)
        p_before = executed(Q)
        after = np.linalg.norm(p_after - T[:, :3, 3], axis=1)[ok]
        before = np.linalg.norm(p_before - T[:, :3, 3], axis=1)[ok]
        pred = float(np.sqrt(np.mean(res.predicted_after[ok] ** 2)))
        rms = float(np.sqrt(np.mean(after**2)))
        print(
            f"{label:<40} {int((~ok).sum()):>7d} {np.sqrt(np.mean(before**2)) * 1e3:>8.4f} mm"
            f" {before.max() * 1e3:>8.4f} mm {rms * 1e3:>7.4f} mm {after.max() * 1e3:>7.4f} mm {pred * 1e3:>7.4f} mm"
            f" {rms / pred:>6.2f} {t_comp / args.positions * 1e6:>12.2f}"
        )
    identified_2 = car.model()
    t_ik = median_time(lambda: dv.ik_batch(identified_2, T, Q))
    print(
        f"{'ik_batch (identified, from the program)':<40} {'':>7} {'':>11} {'':>11} {'':>10} {'':>10} {'':>10} {'':>6}"
        f" {t_ik / args.positions * 1e6:>12.2f}"
    )
    print("aims: after <= 0.05 mm RMS; after / predicted <= 1.5")


if __name__ == "__main__":
    main()
