"""Monte Carlo accuracy of the identification methods on Hayat et al.'s protocols (Table II).

For each protocol (90 and 30 degree ranges) and method, simulate the KR5 (Table III) with 0.02 mm point
noise, identify, and report RMS over the runs of: axis direction error, axis position error (distance of
the true circle centre from the identified line), every DH parameter's error, the RMS tool-position error
of the identified model (DH and ED-H) over 1,000 random configurations, and how the reported sigmas compare
with the Monte Carlo spread (ratio 1 = honest). Prints tables; run `python benchmarks/bench_identify.py --runs 100`.

``--realistic RUNS``: Monte Carlo on recordings with the effects of real ones (tests/real_effects.py: reading errors
of 30-200 arcsec with offset and scale errors, home drift 0.2 mm, 0.02 mm tracker noise; and the exact-readings
case): per method the RMS axis-position error, reported sigma / Monte Carlo spread of every DH parameter (median
and the share within 0.8-1.25; theta against the truth seen through the readings: a reading offset is a theta
offset), the multi-target check (``--targets`` targets on one body under the same motion and readings, each
identified alone: the share of joints and target pairs whose axes agree within their combined sigmas, chi-square
of position and direction across the axis at the 99 % level), the model ``auto`` chose and the parameters outside
0.8-1.25 (``--protocols`` picks the protocols here too; the band needs ~200 runs: at 40 an honest sigma falls
outside it for ~6 % of parameters by sampling alone). Then the shared fits
(issue 12, several targets per pose and 6-DoF poses): ``auto`` on the ``--targets`` targets at once (one fit with
shared axes, the tool orientation from the nest) and on 6-DoF poses of the first target (orientation noise 1e-4
rad): the same columns, the share of axes within their sigmas of the truth (chi-square, 99 %) and of the tool
orientation (3 degrees of freedom, 99 %), and its RMS error against its mean sigma. How identify scales with the
points per sweep (time, peak memory, growth exponent): ``benchmarks/bench_scale_identify.py``.

``--tracker RUNS``: Monte Carlo of the tracker's range/angle noise model (issue 12; the points drawn with a tracker's
noise, ``--tracker-noise`` "sigma_range_um,sigma_angle_arcsec,x,y,z_m", default 5 um, 5 arcsec at (3, 0, 1) m,
2.1-3.2 m from the KR5's points; exact readings, or ``--tracker-readings`` lo,hi arcsec): the global fit with the
model and the isotropic one on the same data, per joint the RMS axis-position error, its ratio to the mean reported
sigma (1 = honest) and the isotropic fit's RMS error over the model's (the accuracy gained).
"""

from __future__ import annotations

import argparse
import collections
import math
import sys
import time
from pathlib import Path

import numpy as np

import denavit as dv
from denavit import sweeps as sw

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from real_effects import (  # noqa: E402 (the simulator of real effects the tests use)
    ARCSEC,
    CHI2_99,
    NEST,
    axis_chi2,
    recordings,
)

from denavit.fitting.joint import TrackerNoise  # noqa: E402
from denavit.geometry import matrix_rotvec  # noqa: E402

METHODS = ["kasa", "hyper", "geometric", "readings", "global"]


def line_errors(res, truth_axes, p_tool_home):
    d_err, p_err = [], []
    for j in range(6):
        n_t = truth_axes.directions[j]
        n_i = res.axes.directions[j]
        d_err.append(np.arctan2(np.linalg.norm(np.cross(n_t, n_i)), n_t @ n_i))
        c_t = truth_axes.points[j] + n_t * ((p_tool_home - truth_axes.points[j]) @ n_t)  # true circle centre
        r = c_t - res.axes.points[j]
        p_err.append(np.linalg.norm(r - n_i * (r @ n_i)))
    return np.array(d_err), np.array(p_err)


def tracker_mc(runs: int, points: int, tracker: TrackerNoise, reading_arcsec, protocols) -> None:
    """The tracker noise model against the isotropic fit on the same data (module docstring, ``--tracker``)."""
    truth = dv.load_robot("kr5").model()
    home = np.radians(sw.PAPER_HOME_DEG)
    T = np.eye(4)
    T[:3, 3] = (0.05, 0.03, 0.10)
    ax, ph = dv.axes(truth, home), dv.fk(truth.with_tool(T), home)[:3, 3]
    for protocol in protocols:
        ranges = np.radians(sw.PAPER_RANGES_DEG[protocol])
        err, sig, err_iso, sig_iso = [], [], [], []
        t0 = time.perf_counter()
        for run in range(runs):
            s = recordings(
                truth, home, ranges, points=points, tracker_noise=tracker, reading_arcsec=reading_arcsec, seed=run
            )[0]
            for e, sg, kw in ((err, sig, {"tracker_noise": tracker}), (err_iso, sig_iso, {})):
                res = dv.identify(s, method="global", **kw)
                e.append(line_errors(res, ax, ph)[1])
                sg.append([f.sigma_point_perp for f in res.fits])
        err, sig, err_iso, sig_iso = map(np.array, (err, sig, err_iso, sig_iso))
        rms, rms_iso = np.sqrt(np.mean(err**2, axis=0)), np.sqrt(np.mean(err_iso**2, axis=0))
        print(
            f"\n=== tracker noise {tracker.sigma_range * 1e6:g} um, {tracker.sigma_angle / ARCSEC:g} arcsec at"
            f" {tracker.position} m, {protocol} degree protocol, {points} points per sweep, readings"
            f" {str(reading_arcsec) + ' arcsec' if reading_arcsec else 'exact'}, {runs} runs"
            f" ({time.perf_counter() - t0:.1f} s)"
        )
        print(
            "joint   rms err model [um]   err / sigma model   rms err isotropic [um]   err / sigma isotropic   gain"
            " (isotropic / model)"
        )
        for j in range(6):
            print(
                f"{j + 1:5d}   {rms[j] * 1e6:20.3g}   {rms[j] / sig[:, j].mean():17.3f}   {rms_iso[j] * 1e6:22.3g}  "
                f" {rms_iso[j] / sig_iso[:, j].mean():21.3f}   {rms_iso[j] / rms[j]:24.3f}"
            )
        print(
            f"pooled err / sigma: model {np.sqrt(np.mean((err / sig) ** 2)):.3f}, isotropic"
            f" {np.sqrt(np.mean((err_iso / sig_iso) ** 2)):.3f}; gain geometric mean"
            f" {math.exp(np.mean(np.log(rms_iso / rms))):.3f}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--points", type=int, default=40)
    ap.add_argument("--noise-mm", type=float, default=0.02)
    ap.add_argument("--methods", default=",".join(METHODS), help="comma-separated subset of " + ",".join(METHODS))
    ap.add_argument("--protocols", default="90,30")
    ap.add_argument(
        "--realistic", type=int, default=0, metavar="RUNS", help="Monte Carlo runs of the realistic cases (0: skip)"
    )
    ap.add_argument(
        "--targets", type=int, default=3, help="targets on one body for the multi-target check (1-4; 1: skip)"
    )
    ap.add_argument("--skip-paper", action="store_true", help="skip the paper protocol tables")
    ap.add_argument(
        "--no-shared",
        action="store_true",
        help="skip the shared fits (several targets at once, 6-DoF poses) of --realistic",
    )
    ap.add_argument(
        "--tracker", type=int, default=0, metavar="RUNS", help="Monte Carlo runs of the tracker noise model (0: skip)"
    )
    ap.add_argument(
        "--tracker-noise", default="5,5,3,0,1", help="sigma_range um, sigma_angle arcsec, tracker x, y, z m"
    )
    ap.add_argument("--tracker-readings", default=None, help="lo,hi arcsec: the readings' white error (default exact)")
    args = ap.parse_args()
    methods = args.methods.split(",")
    if args.tracker:
        v = [float(x) for x in args.tracker_noise.split(",")]
        rd = None if args.tracker_readings is None else tuple(float(x) for x in args.tracker_readings.split(","))
        tracker_mc(
            args.tracker,
            args.points,
            TrackerNoise(v[0] * 1e-6, v[1] * ARCSEC, tuple(v[2:5])),
            rd,
            [int(p) for p in args.protocols.split(",")],
        )
    if args.realistic:
        realistic(
            args.realistic,
            args.points,
            methods if "auto" in methods else [m for m in methods if m != "hyper"] + ["auto"],
            args.targets,
            [int(p) for p in args.protocols.split(",")],
            shared=not args.no_shared,
        )
    if args.skip_paper:
        return
    kr5 = dv.load_robot("kr5")
    truth = kr5.model()
    home = np.radians(sw.PAPER_HOME_DEG)
    tool = np.array([0.05, 0.03, 0.10])
    T_ft = np.eye(4)
    T_ft[:3, 3] = tool
    truth_tool = truth.with_tool(T_ft)
    truth_axes = dv.axes(truth, home)
    p_home = dv.fk(truth_tool, home)[:3, 3]
    qs = np.random.default_rng(99).uniform(truth.lower, truth.upper, (1000, 6))
    p_true = dv.fk_batch(truth_tool, qs)[:, :3, 3]
    names = ["d", "theta", "a", "alpha"]
    print(
        f"KR5 (Hayat Table III), {args.points} points per sweep, {args.noise_mm} mm noise, {args.runs} Monte Carlo runs"
        " per cell"
    )
    for protocol in [int(p) for p in args.protocols.split(",")]:
        ranges = np.radians(sw.PAPER_RANGES_DEG[protocol])
        rows = {}
        t0 = time.perf_counter()
        for m in methods:
            de, pe, perr, sig, tool_dh, tool_edh = [], [], [], [], [], []
            for run in range(args.runs):
                s = sw.simulate(
                    truth,
                    home=home,
                    ranges=ranges,
                    points_per_sweep=args.points,
                    tool_point=tool,
                    noise=args.noise_mm * 1e-3,
                    seed=1000 * protocol + run,
                )
                res = dv.identify(s, method=m, nominal=kr5)
                d, p = line_errors(res, truth_axes, p_home)
                de.append(d)
                pe.append(p)
                diff = res.table.params - kr5.table.params
                diff[:, [1, 3]] = (diff[:, [1, 3]] + np.pi) % (2 * np.pi) - np.pi
                perr.append(diff)
                sig.append(res.sigma)
                model_dh = res.model()
                tool_dh.append(np.sqrt(np.mean(np.sum((dv.fk_batch(model_dh, qs)[:, :3, 3] - p_true) ** 2, axis=1))))
                edh = dv.identify(s, method=m, nominal=kr5, convention="edh") if m in ("kasa", "global") else None
                if edh is not None:
                    tool_edh.append(
                        np.sqrt(np.mean(np.sum((dv.fk_batch(edh.model(), qs)[:, :3, 3] - p_true) ** 2, axis=1)))
                    )
            perr, sig = np.array(perr), np.array(sig)
            spread = perr.std(axis=0)
            mask = spread > 1e-12
            ratio = np.median((sig.mean(axis=0)[mask]) / spread[mask])
            rows[m] = {
                "dir_urad": 1e6 * np.sqrt(np.mean(np.array(de) ** 2, axis=0)),
                "pos_mm": 1e3 * np.sqrt(np.mean(np.array(pe) ** 2, axis=0)),
                "param_rms": np.sqrt(np.mean(perr**2, axis=0)),
                "sigma_ratio": ratio,
                "sigma_ratios": (sig.mean(axis=0)[mask]) / spread[mask],
                "tool_dh_mm": 1e3 * np.mean(tool_dh),
                "tool_edh_mm": 1e3 * np.mean(tool_edh) if tool_edh else float("nan"),
            }
        dt = time.perf_counter() - t0
        print(f"\n=== {protocol} degree protocol (Hayat Table II) — {dt:.0f} s ===")
        print("RMS axis-position error per joint (mm), perpendicular to the identified axis:")
        print(f"{'method':<10}" + "".join(f"{'J' + str(j + 1):>9}" for j in range(6)) + f"{'vs kasa':>10}")
        ref = rows.get("kasa", next(iter(rows.values())))["pos_mm"]
        for m in methods:
            r = rows[m]["pos_mm"]
            print(
                f"{m:<10}"
                + "".join(f"{v:9.4f}" for v in r)
                + f"{np.sqrt(np.mean(ref**2)) / np.sqrt(np.mean(r**2)):9.1f}x"
            )
        print("RMS axis-direction error per joint (urad):")
        for m in methods:
            print(f"{m:<10}" + "".join(f"{v:9.1f}" for v in rows[m]["dir_urad"]))
        print("RMS DH parameter error (mm / mdeg), joints 1..6:")
        for k, name in enumerate(names):
            scale, unit = (1e3, "mm") if name in ("d", "a") else (np.degrees(1) * 1e3, "mdeg")
            for m in methods:
                print(
                    f"  {name:>5} [{unit:>4}] {m:<10}"
                    + "".join(f"{v:9.3f}" for v in rows[m]["param_rms"][:, k] * scale)
                )
        print(
            "Tool-position RMS error over 1,000 random configurations (mm), and reported sigma / Monte Carlo spread"
            " (median over parameters; 1 = honest):"
        )
        print(f"{'method':<10}{'DH model':>10}{'ED-H model':>12}{'sigma/spread':>14}{'within 20%':>12}")
        for m in methods:
            r = rows[m]
            frac = np.mean(np.abs(r["sigma_ratios"] - 1) <= 0.2)
            print(f"{m:<10}{r['tool_dh_mm']:10.4f}{r['tool_edh_mm']:12.4f}{r['sigma_ratio']:14.2f}{100 * frac:11.0f}%")


CASES = {
    "exact readings": {},
    "readings 30-200 arcsec": {"reading_arcsec": (30, 200), "offset_deg": 0.05, "scale": 3e-4},
    "readings 30-200 arcsec + drift 0.2 mm": {
        "reading_arcsec": (30, 200),
        "offset_deg": 0.05,
        "scale": 3e-4,
        "drift": 2e-4,
    },
}


class _Truth:
    """The true axis j at home as a fit with no uncertainty (for axis_chi2), at the foot of a fit's point."""

    def __init__(self, axes, j, fit):
        c, n = np.asarray(axes.points[j]), np.asarray(axes.directions[j])
        self.point, self.direction, self.cov = c + n * ((fit.point - c) @ n), n, np.zeros((6, 6))


def realistic(runs: int, points: int, methods: list, targets: int = 3, protocols=(90, 30), shared: bool = True) -> None:
    kr5 = dv.load_robot("kr5")
    truth = kr5.model()
    home = np.radians(sw.PAPER_HOME_DEG)
    T_ft = np.eye(4)
    T_ft[:3, 3] = NEST[0]
    truth_axes, p_home = dv.axes(truth, home), dv.fk(truth.with_tool(T_ft), home)[:3, 3]
    R_true = dv.fk(truth.with_tool(np.eye(4)), home)[:3, :3]
    for protocol in protocols:
        ranges = np.radians(sw.PAPER_RANGES_DEG[protocol])
        print(
            f"\n=== realistic recordings, {protocol} degree protocol, {points} points per sweep, 0.02 mm tracker noise,"
            f" {runs} runs, {targets} targets ==="
        )
        print(
            f"{'case':<40}{'method':<11}{'axis err mm':>12}{'vs kasa':>8}{'sigma/spread':>14}{'in 0.8-1.25':>13}"
            f"{'targets agree':>15}"
            "   auto chose; out of the band"
        )
        shared_rows = []
        for case, kw in CASES.items():
            kasa = None
            for label, how in (
                ([(f"auto x{targets} targets", "targets")] if targets > 1 else []) + [("auto 6-DoF", "poses")]
            ) * shared:
                est, sig, pe, chose, within, rot_c2, rot_e, rot_s = [], [], [], collections.Counter(), [], [], [], []
                for run in range(runs):
                    if how == "targets":
                        recs = recordings(
                            truth,
                            home,
                            ranges,
                            points=points,
                            seed=10_000 * protocol + run,
                            targets=NEST[:targets],
                            **kw,
                        )
                        data = sw.merge_targets(recs, NEST[:targets])
                    else:
                        data = recordings(
                            truth,
                            home,
                            ranges,
                            points=points,
                            seed=10_000 * protocol + run,
                            poses=True,
                            noise_rot=1e-4,
                            **kw,
                        )[0]
                    res = dv.identify(data, nominal=kr5)
                    d = res.table.params - kr5.table.params
                    d[:, 1] += data.home - home
                    d[:, [1, 3]] = (d[:, [1, 3]] + np.pi) % (2 * np.pi) - np.pi
                    est.append(d)
                    sig.append(res.sigma)
                    pe.append(line_errors(res, truth_axes, p_home)[1])
                    chose[res.method] += 1
                    within += [
                        axis_chi2(f, _Truth(truth_axes, j, f), kind)[0] <= CHI2_99[4]
                        for j, (f, kind) in enumerate(zip(res.fits, data.kinds, strict=True))
                    ]
                    e = matrix_rotvec(np.asarray(res.axes.T_world_tool)[:3, :3] @ R_true.T)
                    rot_c2.append(float(e @ np.linalg.solve(res.tool_rotation_cov, e)) <= CHI2_99[3])
                    rot_e.append(float(e @ e))
                    rot_s.append(res.tool_rotation_sigma)
                est, sig = np.array(est), np.array(sig)
                spread = est.std(axis=0, ddof=1)
                free = spread > 1e-9  # (theta_6 included: the tool frame is identified here)
                ratio = np.sqrt(np.mean(sig**2, axis=0))[free] / spread[free]
                pos = 1e3 * math.sqrt(np.mean(np.array(pe) ** 2))
                shared_rows.append(
                    f"{case:<40}{label:<18}{pos:12.4f}{np.median(ratio):14.2f}"
                    f"{100 * np.mean((ratio >= 0.8) & (ratio <= 1.25)):12.0f}%"
                    f"{100 * np.mean(within):13.0f}%{100 * np.mean(rot_c2):12.0f}"
                    f"%{math.degrees(math.sqrt(np.mean(rot_e))) * 3600:10.3g}"
                    f"{math.degrees(np.mean(rot_s)) * 3600:10.3g}   " + ", ".join(f"{k} {v}" for k, v in chose.items())
                )
            for method in methods:
                est, sig, pe, chose, agree = [], [], [], collections.Counter(), []
                for run in range(runs):
                    recs = recordings(
                        truth,
                        home,
                        ranges,
                        points=points,
                        seed=10_000 * protocol + run,
                        targets=NEST[: max(targets, 1)],
                        **kw,
                    )
                    res = dv.identify(recs[0], method=method, nominal=kr5)
                    d = res.table.params - kr5.table.params
                    d[:, 1] += recs[0].home - home  # a reading offset / scale error at home is a true theta offset
                    d[:, [1, 3]] = (d[:, [1, 3]] + np.pi) % (2 * np.pi) - np.pi
                    est.append(d)
                    sig.append(res.sigma)
                    pe.append(line_errors(res, truth_axes, p_home)[1])
                    if method == "auto":
                        chose[res.method] += 1
                    others = [res] + [dv.identify(r, method=method, nominal=kr5) for r in recs[1:]]
                    for a in range(len(others)):
                        for b in range(a + 1, len(others)):
                            for fa, fb, kind in zip(others[a].fits, others[b].fits, recs[0].kinds, strict=True):
                                c2, k = axis_chi2(fa, fb, kind)
                                agree.append(c2 <= CHI2_99[k])
                est, sig = np.array(est), np.array(sig)
                spread = est.std(axis=0, ddof=1)
                free = spread > 1e-9
                free[-1, 1] = False  # theta_6 is fixed by the tool frame, copied from the nominal (not identified here)
                ratio = np.sqrt(np.mean(sig**2, axis=0))[free] / spread[free]
                inband = np.mean((ratio >= 0.8) & (ratio <= 1.25))
                cols = list(kr5.table.columns)
                names = [
                    f"{cols[c]}{j + 1} {r:.2f}"
                    for (j, c), r in zip(np.argwhere(free), ratio, strict=True)
                    if not 0.8 <= r <= 1.25
                ]
                pos = 1e3 * math.sqrt(np.mean(np.array(pe) ** 2))
                kasa = pos if method == "kasa" else kasa
                gain = f"{kasa / pos:7.1f}x" if kasa else f"{'-':>8}"
                ag = f"{100 * np.mean(agree):14.0f}%" if agree else f"{'-':>15}"
                print(
                    f"{case:<40}{method:<11}{pos:12.4f}{gain}{np.median(ratio):14.2f}{100 * inband:12.0f}%{ag}   "
                    + (", ".join(f"{k} {v}" for k, v in chose.items()) if chose else "")
                    + ("; " + ", ".join(names) if names else "")
                )
        if not shared:
            continue
        print(f"shared fits (one fit with shared axes; tool orientation identified), {protocol} degree protocol:")
        print(
            f"{'case':<40}{'data':<18}{'axis err mm':>12}{'sigma/spread':>14}{'in 0.8-1.25':>13}{'axes in 99%':>14}"
            f"{'tool in 99%':>13}{'tool err':>10}{'sigma':>10}"
            "   auto chose   (tool orientation error and mean sigma in arcsec)"
        )
        for row in shared_rows:
            print(row)


if __name__ == "__main__":
    main()
