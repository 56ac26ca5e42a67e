"""Monte Carlo of identify's ``auto`` choices (home drift, reading scales, joint compliance) on 6-DoF poses against
points alone, same protocol: does auto fit effects that are not there, does it find those that are, and does it take
one for another?

Built-in UR5 (about the home of issue 36), KR 210 and KR5, every joint swept 90 degrees (home +-45 deg), 50 poses per
sweep, 0.02 mm point noise, 0.005 deg orientation noise (6-DoF poses: ``dv.simulate(..., poses=True,
noise_rot=...)``), the tool point 30, 20, 100 mm on the flange. Cases, each on points alone and on 6-DoF poses:

- ``rigid``: exact readings, one home point, rigid joints: every model extension auto fits is a false positive;
- ``scale``: 200 ppm reading scale errors on joints 2 and 3 (the joint turns 1.0002 times its reading's motion from
  home): "found" is fitted with both scales nearer 200 ppm than 0;
- ``drift``: the tool point moves between sweeps (N(0, 30 um) per coordinate per sweep, the orientation unchanged):
  "found" is a home point per sweep chosen;
- ``compliant`` (robots with inertials): every joint holding torque twists by ``--sizes`` x 0.3 mrad under its largest
  gravity torque at the rated payload (RATED; the KR 210 at 1x is tests/test_identify_compliance.py's), the sweeps at
  the declared payload; "found" is the compliances fitted, and the error ratio that of held-out points (no payload,
  joint ranges shifted 10 deg, +-35 deg) predicted by auto over the rigid global fit's; "held um" auto's held-out RMS.

The UR5's and the KR 210's sweeps declare a payload at the flange (PAYLOADS: 5 and 100 kg; their link inertials give
the gravity torques), so auto considers the joints' compliance (``--payload 0``: not declared); the KR5 carries no
inertials (compliance not considered). Per case: how often auto fits a drift, scales, compliances; auto's RMS
axis-position error (over the joints, the distance of the true circle centre from the identified line) over that of
``method="global"`` (one home point, exact scales, rigid: the true model on ``rigid``, the model without the effect
elsewhere), median and max; and the criteria auto reported, median, min and max: the drift's (chi-square less its 15
ln n; positive: a drift), the scales' (2 ln of their marginal likelihood ratio less ln n) and the compliances'
(chi-square less ln n per free one).

Before and after the drift's choice by the Wald form and the joint fit's orientation weight at its fixed point (20
seeds): on rigid poses the drift criterion's median -286 (UR5) and -272 (KR5), expected 15 - 15 ln 1800 = -97, now
-100 and -98; ``--cases drift --drift 8 --payload 0``: a drift found on poses in 0 and 0 of 20 runs, now 13 and 12
(points 5 and 4, now 9 and 7).

Before and after the three effects chosen by one rule, stepwise, each tested with the others chosen (they had been
chosen compliances first, each alone): ``--runs 20 --robots ur5,kr210,kr5 --cases rigid,scale,drift,compliant``,
runs fitting compliances / "found" (points, poses):

=================  ===================  ===================
case               before               after
=================  ===================  ===================
UR5 scale          20/0, 5/15           0/18, 0/20
KR 210 scale       20/20, 20/20         0/20, 0/20
UR5 drift          13/20, 2/20          0/20, 0/20
KR 210 drift       12/20, 11/20         0/20, 0/20
UR5 compl 1x       20, 20               20, 20
UR5 compl 0.4x     20, 20               10, 20
KR 210 compl 1x    20, 20               20, 20
KR 210 compl 0.4x  20, 20               20, 20
=================  ===================  ===================

Without a payload (``--payload 0``) the scales are found on UR5 points in 17 of 20 before, 18 after, in 20 of 20
elsewhere; the UR5's axes on scale errors 1.22x the global fit's error before (median, points), 0.25x after, as
without a payload. The held-out error on compliant data is unchanged (KR 210 median 38.0/36.2 um at 1x, 36.9/36.2
um at 0.4x, 0.13-0.32x the rigid fit's), rigid data fit nothing in 19-20 of 20 runs as before (a chance scale in 1),
KR5 unchanged. Left: the UR5 at 0.4x on points (0.12 mrad under its largest torque at 5 kg), where the compliances and
scale errors on joints 2 and 3 explain the sweeps equally well (alone each gains 4-26 over its penalty, the sums of
squares on common weights fall by 27-47 either way, and together neither pays), took the scales in 10 of 20 runs:
held-out 43.0 um against 36.7 (the rigid fit's 0.93x; poses, which tell them apart, 20 of 20).

Run: ``python benchmarks/bench_identify_choice_poses.py --runs 20`` (single process, about 5 minutes; with every
robot and case about 12).
"""

from __future__ import annotations

import argparse
import math
import re
import time
from dataclasses import replace

import numpy as np

import denavit as dv

HOMES = {
    "ur5": np.radians([10.79, 44.5, 36.14, -1.70, 3.45, 42.87]),
    "kr5": np.radians([10.0, -60.0, 80.0, 5.0, 40.0, 20.0]),
    "kr210": np.radians([0.0, -90.0, 90.0, 0.0, 30.0, 0.0]),
}
TOOL = np.array([0.03, 0.02, 0.10])
NOISE, NOISE_ROT = 2e-5, math.radians(0.005)
PPM, SCALED = 200e-6, (1, 2)
DRIFT = 3e-5  # m, per coordinate per sweep
#: kg at the flange declared on every sweep (compliance considered where the nominal has inertials), and the rated
#: payload the compliant case's compliances are sized at
PAYLOADS = {"ur5": 5.0, "kr210": 100.0}
RATED = {"ur5": 5.0, "kr210": 210.0}
SIZES = (1.0, 0.4)  # the compliant case's compliances: times 0.3 mrad under each joint's largest torque at RATED


def compliance_of(robot: str, size: float) -> np.ndarray:
    """Every joint holding torque twists by ``size`` x 0.3 mrad under its largest gravity torque over the sweeps at
    the rated payload (tests/test_identify_compliance.py's KR 210 at size 1)."""
    from denavit.calibration.compliance import gravity_torques  # noqa: PLC0415

    m, home = dv.load_robot(robot).model(), HOMES[robot]
    q = home + np.linspace(-1, 1, 91)[:, None, None] * np.diag(np.full(6, math.radians(45)))[None]
    tmax = np.abs(gravity_torques(m, q.reshape(-1, 6), np.tile([RATED[robot], 0, 0, 0], (q.size // 6, 1)))).max(0)
    return np.where(tmax > 1e-6 * tmax.max(), size * 3e-4 / np.maximum(tmax, 1e-300), 0.0)


def compliant(
    robot: str,
    k: np.ndarray,
    payload: float,
    seed: int,
    poses: bool,
    points: int,
    shift: float = 0.0,
    half: float = 45.0,
) -> dv.SweepSet:
    """Sweeps of the arm whose joint i's link sits at q_i - k_i tau_i(q, payload) (payload at the flange, carried on
    every sweep), the tool point (and with ``poses`` the flange's orientation) seen with NOISE (NOISE_ROT)."""
    from denavit import _core  # noqa: PLC0415
    from denavit.calibration.compliance import gravity_torques  # noqa: PLC0415
    from denavit.geometry import rotvec_matrix  # noqa: PLC0415

    m, home = dv.load_robot(robot).model(), HOMES[robot]
    ranges = np.stack([home + math.radians(shift - half), home + math.radians(shift + half)], axis=1)
    ss = dv.simulate(robot, home=home, ranges=ranges, points_per_sweep=points, tool_point=TOOL, seed=seed)
    rng = np.random.default_rng(seed + 1000)
    out = []
    for s in ss.sweeps:
        load = np.tile([payload, 0.0, 0.0, 0.0], (len(s.q), 1))
        F = np.asarray(_core.fk_batch(m, s.q - k * gravity_torques(m, s.q, load)))
        p = F[:, :3, :3] @ TOOL + F[:, :3, 3] + rng.normal(0, NOISE, (len(s.q), 3))
        rot = None
        if poses:
            rot = np.array([rotvec_matrix(v) for v in rng.normal(0, NOISE_ROT, (len(s.q), 3))]) @ F[:, :3, :3]
        out.append(replace(s, points=p, rotations=rot, payload=load))
    return replace(ss, sweeps=out)


def held_out_rms(idf, ss, model) -> float:
    """RMS 3-D error of the points of ``ss`` predicted by ``idf``'s axes and home tool point (the readings less its
    compliances' deflection): tests/test_identify_compliance.py's held_out_rms."""
    from denavit.calibration.compliance import gravity_torques  # noqa: PLC0415

    c, errs = idf.compliance, []
    for s in ss.sweeps:
        dq = s.q - ss.home
        if c is not None:
            dq = dq - c["k"] * (gravity_torques(model, s.q, s.payload) - c["torque_home"])
        for q, meas in zip(dq, s.points, strict=True):
            y = np.asarray(idf.tool_point, dtype=float)
            for f, a in reversed(list(zip(idf.fits, q, strict=True))):
                n, v = f.direction, y - f.point
                y = f.point + v * np.cos(a) + np.cross(n, v) * np.sin(a) + n * (n @ v) * (1 - np.cos(a))
            errs.append(np.linalg.norm(y - meas))
    return float(np.sqrt(np.mean(np.square(errs))))


def data(robot: str, seed: int, poses: bool, case: str, points: int, drift: float = DRIFT) -> dv.SweepSet:
    home = HOMES[robot]
    ranges = np.stack([home - math.radians(45), home + math.radians(45)], axis=1)
    kw = {"home": home, "ranges": ranges, "points_per_sweep": points, "noise": NOISE, "seed": seed}
    if poses:
        kw.update(poses=True, noise_rot=NOISE_ROT)
    if case == "drift":  # sweep s from a simulation with its own tool point (same seed: the same noise draws)
        d = np.random.default_rng(10_000 + seed).normal(0.0, drift, (6, 3))
        s = dv.simulate(robot, tool_point=TOOL, **kw)
        return replace(
            s, sweeps=[dv.simulate(robot, tool_point=TOOL + d[k], **kw).sweeps[k] for k in range(len(s.sweeps))]
        )
    s = dv.simulate(robot, tool_point=TOOL, **kw)
    if case == "scale":
        sc = np.zeros(6)
        sc[list(SCALED)] = PPM
        s = replace(s, sweeps=[replace(x, q=home + (x.q - home) / (1 + sc)) for x in s.sweeps])
    return s


class Truth:
    def __init__(self, robot: str):
        m = dv.load_robot(robot).model()
        T = np.eye(4)
        T[:3, 3] = TOOL
        self.axes, self.p = dv.axes(m, HOMES[robot]), dv.fk(m.with_tool(T), HOMES[robot])[:3, 3]

    def axis_error(self, res) -> float:
        e = []
        for j in range(len(res.fits)):
            n_t, n_i = self.axes.directions[j], res.axes.directions[j]
            c = self.axes.points[j] + n_t * ((self.p - self.axes.points[j]) @ n_t)
            r = c - res.axes.points[j]
            e.append(np.linalg.norm(r - n_i * (r @ n_i)))
        return float(np.sqrt(np.mean(np.square(e))))


def criteria(notes: list[str]) -> tuple[float, float, float]:
    """(the drift's criterion less its penalty (the BIC), positive for a drift; the scales' 2 ln LR less its penalty;
    the compliances' chi-square less its penalty) from auto's notes."""
    bic = lr = kc = math.nan
    for n in notes:
        m = re.match(r"auto: (readings|global) \(.*?BIC lower by ([-0-9.e+]+)", n)  # (the rule before)
        if m:
            bic = float(m.group(2)) * (1 if m.group(1) == "readings" else -1)
        m = re.match(r"auto: (?:readings|global) \(.*?chi\^2 ([-0-9.e+]+) of the home.*? = ([-0-9.e+]+)", n)
        if m:
            bic = float(m.group(1)) - float(m.group(2))
        m = re.search(r"2 ln\(marginal likelihood ratio\) ([-0-9.e+]+) (?:>|<=) ln \d+ = ([-0-9.e+]+)", n)
        if m:
            lr = float(m.group(1)) - float(m.group(2))
        m = re.search(r"chi\^2 ([-0-9.e+]+) of the compliances (?:>|<=) \d+ ln \d+ = ([-0-9.e+]+)", n)
        if m:
            kc = float(m.group(1)) - float(m.group(2))
    return bic, lr, kc


def run(robot: str, case: str, poses: bool, args, size: float = 0.0) -> dict:
    """auto and the plain global fit on ``args.runs`` seeds of one case; per run what auto fitted, "found", the error
    ratio auto/global (axes; held-out points in the compliant case) and auto's criteria."""
    truth = Truth(robot)
    out = {k: [] for k in ("drift", "scales", "found", "compliance", "ratio", "held", "bic", "lr", "kc", "t")}
    payload = PAYLOADS.get(robot, 0.0) if args.payload is None else args.payload
    opts = {"nominal": robot}
    if payload and dv.load_robot(robot).inertials is not None:
        opts["payload"] = payload
    k = compliance_of(robot, size) if case == "compliant" else None
    model = dv.load_robot(robot).model()
    for r in range(args.runs):
        seed = args.seed + r
        if case == "compliant":
            s = compliant(robot, k, payload, seed, poses, args.points)
        else:
            s = data(robot, seed, poses, case, args.points, args.drift * 1e-6)
        t0 = time.perf_counter()
        a = dv.identify(s, **opts)
        out["t"].append(time.perf_counter() - t0)
        g = dv.identify(s, method="global", **opts, compliance=False)
        out["drift"].append(a.method == "readings")
        out["scales"].append(a.reading_scale is not None)
        out["compliance"].append(a.compliance is not None)
        if case == "scale":
            v = a.reading_scale[list(SCALED)] if a.reading_scale is not None else np.zeros(2)
            out["found"].append(bool(a.reading_scale is not None and np.all(np.abs(v - PPM) < np.abs(v))))
        elif case == "compliant":
            out["found"].append(a.compliance is not None)
        else:
            out["found"].append(a.method == "readings")
        if case == "compliant":  # held out: no payload, other joint ranges
            test = compliant(robot, k, 0.0, 5000 + seed, False, args.points, shift=10.0, half=35.0)
            e = held_out_rms(a, test, model)
            out["held"].append(e)
            out["ratio"].append(e / held_out_rms(g, test, model))
        else:
            out["held"].append(math.nan)
            out["ratio"].append(truth.axis_error(a) / truth.axis_error(g))
        b, lr, kc = criteria(a.notes)
        out["bic"].append(b)
        out["lr"].append(lr)
        out["kc"].append(kc)
    return {k: np.array(v) for k, v in out.items()}


def spread(v) -> str:
    v = v[np.isfinite(v)]
    return f"{np.median(v):6.3g} {v.min():6.3g} {v.max():6.3g}" if len(v) else f"{'-':>20}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--points", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--robots", default="ur5,kr5")
    ap.add_argument("--cases", default="rigid,scale,drift")
    ap.add_argument("--data", default="points,poses", help="points, poses or both")
    ap.add_argument("--drift", type=float, default=DRIFT * 1e6, help="um per coordinate per sweep (case drift)")
    ap.add_argument("--payload", type=float, default=None, help="kg declared (default: the robot's PAYLOADS; 0: none)")
    ap.add_argument("--sizes", default=",".join(f"{x:g}" for x in SIZES), help="case compliant: sizes")
    args = ap.parse_args()
    print(
        f"{args.runs} seeds from {args.seed}, {args.points} poses per sweep, 90 deg arcs, noise {NOISE * 1e3:g} mm"
        f" / {math.degrees(NOISE_ROT):g} deg; counts of runs fitting each extension; error auto/global (axes; held-out"
        " points for compliant: median, max); held-out RMS um (compliant); drift chi2 - pen, scales' 2 ln LR - pen,"
        " compliances' chi2 - pen (median, min, max)"
    )
    print(
        f"{'robot':<5} {'case':<10} {'data':<7}{'drift':>6}{'scales':>7}{'compl':>6}{'found':>6} | {'err ratio':>11} |"
        f" {'held um':>7} | {'drift':>20} | {'scales':>20} | {'compliances':>20} | s/run"
    )
    for robot in args.robots.split(","):
        for case in args.cases.split(","):
            sizes = [float(x) for x in args.sizes.split(",")] if case == "compliant" else [0.0]
            if case == "compliant" and dv.load_robot(robot).inertials is None:
                continue
            for size in sizes:
                for kind in args.data.split(","):
                    r = run(robot, case, kind == "poses", args, size)
                    n = args.runs
                    found = f"{int(r['found'].sum()):3d}/{n}" if case != "rigid" else f"{'-':>6}"
                    name = f"compl{size:g}x" if case == "compliant" else case
                    held = f"{1e6 * np.median(r['held']):7.1f}" if case == "compliant" else f"{'-':>7}"
                    print(
                        f"{robot:<5} {name:<10} {kind:<7}{int(r['drift'].sum()):3d}/{n}"
                        f"{int(r['scales'].sum()):4d}/{n}{int(r['compliance'].sum()):3d}/{n}{found} |"
                        f" {np.median(r['ratio']):5.2f} {r['ratio'].max():5.2f} | {held} | {spread(r['bic']):>20} |"
                        f" {spread(r['lr']):>20} | {spread(r['kc']):>20} | {np.median(r['t']):.1f}",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
