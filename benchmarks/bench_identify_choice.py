"""Monte Carlo of identify's ``auto`` choice of the reading scales (issue 36): does it fit effects that are not there?

The reproduction of the issue: the UR5 swept 30 degrees per joint about an unusual home (``denavit simulate ur5
--home "10.79,44.5,36.14,-1.70,3.45,42.87" --ranges "-4.2,25.8,29.5,59.5,21.1,51.1,-16.7,13.3,-11.5,18.5,27.9,57.9"
--points 50 --noise 0.02 --tool "30,20,100" --seed S``), then ``identify --nominal ur5``, for ``--runs`` seeds, in
three cases:

- exact readings: how often auto fits reading scales, and its axes against those of the readings-exact global fit
  (``method="global"``, the model that is true here): the ratio of their RMS axis-position errors (over the six
  joints, the distance of the true circle centre from the identified line), percentiles over the runs;
- 200 ppm scale errors on joints 2 and 3 (the joint turns 1.0002 times its reading's motion about home), on the same
  30 degree arcs, where the free scales' sigmas are 240-470 ppm (a scale trades with its axis's radial position:
  only the arcs' curvature tells them apart), and on 90 degree arcs (home +-45 deg), where they are about 20-60
  ppm: how often auto fits the scales ("found": fitted, and both scales nearer the truth than zero);
- in each case which of the two models is nearer the truth on the axes (the error the choice is about: the axes
  predict the robot elsewhere), and how often auto's choice is that one, where they differ. "old rule" is the
  choice before issue 36 (any positive median-unbiased spread tau fitted the scales).

Also the reported sigmas' honesty on the exact readings, of auto and of the global fit: per DH parameter, the mean
reported sigma over the RMS error about the truth across the runs (1 = honest; median, range, the share within
0.8-1.25 and the parameters outside it; with 100 runs an honest sigma falls outside that band for a few percent of
the parameters by sampling alone). On 30 degree arcs d and theta of joints 3 and 4 fall outside it for both fits
alike: the UR5's joints 2-4 are parallel, and a DH table's d and theta on nearly parallel axes swing with the
common normal (0.13 m RMS), their sigma with them, so its mean is no scale for its error there.

Run: ``python benchmarks/bench_identify_choice.py --runs 100`` (single process, about 5 minutes).
"""

from __future__ import annotations

import argparse
import importlib
import math
import time

import numpy as np

import denavit as dv
from denavit import sweeps as sw

ident = importlib.import_module("denavit.identification.choice")

HOME = np.radians([10.79, 44.5, 36.14, -1.70, 3.45, 42.87])
RANGES30 = np.radians(
    np.array([-4.2, 25.8, 29.5, 59.5, 21.1, 51.1, -16.7, 13.3, -11.5, 18.5, 27.9, 57.9]).reshape(6, 2)
)
RANGES90 = np.stack([HOME - np.radians(45), HOME + np.radians(45)], axis=1)
TOOL = (0.03, 0.02, 0.10)
SCALED = (1, 2)  # joints 2 and 3 (0-based)
PPM = 200e-6


def data(ranges, seed: int, points: int, scale: np.ndarray | None = None) -> sw.SweepSet:
    """The simulated sweeps; with ``scale`` (n,) the readings err in scale: the joint turns (1 + scale) times its
    reading's motion from home."""
    s = dv.simulate("ur5", home=HOME, ranges=ranges, points_per_sweep=points, noise=2e-5, tool_point=TOOL, seed=seed)
    if scale is None:
        return s
    return sw.SweepSet(
        [sw.Sweep(x.joint, x.points, HOME + (x.q - HOME) / (1 + scale), x.where) for x in s.sweeps],
        s.n_joints,
        s.home,
        s.kinds,
        s.source,
        s.units,
    )


class Truth:
    def __init__(self):
        m = dv.load_robot("ur5").model()
        T = np.eye(4)
        T[:3, 3] = TOOL
        self.axes, self.p = dv.axes(m, HOME), dv.fk(m.with_tool(T), HOME)[:3, 3]
        self.params = dv.load_robot("ur5").table.params

    def axis_error(self, res) -> float:
        """RMS over the joints of the distance of the true circle centre from the identified line (m)."""
        e = []
        for j in range(len(res.fits)):
            n_t, n_i = self.axes.directions[j], res.axes.directions[j]
            c = self.axes.points[j] + n_t * ((self.p - self.axes.points[j]) @ n_t)
            r = c - res.axes.points[j]
            e.append(np.linalg.norm(r - n_i * (r @ n_i)))
        return float(np.sqrt(np.mean(np.square(e))))

    def param_error(self, res) -> np.ndarray:
        d = res.table.params - self.params
        d[:, [1, 3]] = (d[:, [1, 3]] + np.pi) % (2 * np.pi) - np.pi
        return d


def old_rule(*_args):
    """The choice before issue 36: any positive spread tau fitted the scales (no evidence asked for)."""
    return -math.inf, "old rule"


def run_case(truth: Truth, ranges, runs: int, points: int, scale, seed0: int) -> dict:
    """auto, auto by the old rule and the global fit on ``runs`` seeds; per run: scales fitted (new, old), found, the
    axis errors (auto, old, global), the table errors and sigmas of auto."""
    out = {
        k: []
        for k in (
            "fit",
            "fit_old",
            "found",
            "e_auto",
            "e_old",
            "e_glob",
            "perr",
            "sig",
            "t_auto",
            "t_glob",
            "lr",
            "k",
            "perr_g",
            "sig_g",
        )
    }
    new_rule, evidence = ident._scale_penalty, ident._scale_evidence
    seen = {}

    def spy_evidence(s, C):
        out_ = evidence(s, C)
        seen["lr"] = out_[0]
        return out_

    def spy_penalty(k, n_res):
        seen["k"] = k
        return new_rule(k, n_res)

    for r in range(runs):
        s = data(ranges, seed0 + r, points, scale)
        seen.clear()
        ident._scale_evidence, ident._scale_penalty = spy_evidence, spy_penalty
        try:
            t0 = time.perf_counter()
            a = dv.identify(s, nominal="ur5")
            t1 = time.perf_counter()
        finally:
            ident._scale_evidence, ident._scale_penalty = evidence, new_rule
        out["lr"].append(seen.get("lr", math.nan))
        out["k"].append(seen.get("k", math.nan))
        g = dv.identify(s, nominal="ur5", method="global")
        t2 = time.perf_counter()
        ident._scale_penalty = old_rule
        try:
            o = dv.identify(s, nominal="ur5")
        finally:
            ident._scale_penalty = new_rule
        fitted = a.reading_scale is not None
        out["fit"].append(fitted)
        out["fit_old"].append(o.reading_scale is not None)
        if scale is not None and fitted:
            v = a.reading_scale[list(SCALED)]
            out["found"].append(bool(np.all(np.abs(v - scale[list(SCALED)]) < np.abs(v))))
        else:
            out["found"].append(False)
        out["e_auto"].append(truth.axis_error(a))
        out["e_old"].append(truth.axis_error(o))
        out["e_glob"].append(truth.axis_error(g))
        out["perr"].append(truth.param_error(a))
        out["sig"].append(a.sigma)
        out["perr_g"].append(truth.param_error(g))
        out["sig_g"].append(g.sigma)
        out["t_auto"].append(t1 - t0)
        out["t_glob"].append(t2 - t1)
    return {k: np.array(v) for k, v in out.items()}


def agreement(res: dict, chose: np.ndarray) -> str:
    """Among the runs where the old rule fitted the scales (the two models differ): how often the scale fit is
    nearer the truth on the axes (the out-of-sample error), and how often the choice ``chose`` is the nearer model."""
    differ = res["fit_old"]
    if not np.any(differ):
        return "   -"
    better = res["e_old"][differ] < res["e_glob"][differ]  # the scales' fit nearer the truth
    return f"{np.sum(chose[differ] == better):3d}/{np.sum(differ):<3d}"


def honesty(res: dict, fit: str = "") -> tuple[float, float, float, float, str]:
    """Per DH parameter that varies, the mean reported sigma over the RMS error about the truth: (median, min, max,
    share within 0.8-1.25, the parameters outside it)."""
    perr, sig = res["perr" + fit], res["sig" + fit]
    rms = np.sqrt(np.mean(perr**2, axis=0))
    mask = rms > 1e-12
    ratio = sig.mean(axis=0)[mask] / rms[mask]
    names = np.array([[f"{p}{j + 1}" for p in ("d", "theta", "a", "alpha")] for j in range(perr.shape[1])])[mask]
    out = (ratio < 0.8) | (ratio > 1.25)
    return (
        float(np.median(ratio)),
        float(ratio.min()),
        float(ratio.max()),
        float(np.mean(~out)),
        ", ".join(f"{n} {r:.2f}" for n, r in zip(names[out], ratio[out], strict=True)),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--points", type=int, default=50)
    ap.add_argument("--save", help="write every run's figures to this .npz")
    args = ap.parse_args()
    truth = Truth()
    sc = np.zeros(6)
    sc[list(SCALED)] = PPM
    cases = [
        ("exact readings, 30 deg arcs", RANGES30, None, 0),
        ("200 ppm on J2, J3, 30 deg arcs", RANGES30, sc, 0),
        ("exact readings, 90 deg arcs", RANGES90, None, 0),
        ("200 ppm on J2, J3, 90 deg arcs", RANGES90, sc, 0),
    ]
    print(
        f"UR5, home {np.round(np.degrees(HOME), 2).tolist()} deg, {args.points} points per sweep, 0.02 mm noise, tool"
        f" {TOOL} m, {args.runs} seeds per case"
    )
    print(
        "Scales fitted: by auto (ln n, n the residual count), by the old rule, and by the same evidence with the BIC's"
        " n the count of scales (ln k). Found: fitted, both scales nearer 200 ppm than 0."
    )
    print(
        "Agrees: among the runs where the old rule fitted the scales, how often the choice is the model nearer the"
        " truth on the axes."
    )
    print(
        f"{'case':<32}{'fitted':>7}{'old':>6}{'ln k':>6}{'found':>7} | auto/global axis error: p50   p90   p95   max"
        f" <=1.5x | {'RMS um: auto':>12}{'global':>7}{'old':>6} | scales nearer  agrees: auto  ln k"
    )
    results = {}
    for name, ranges, scale, seed0 in cases:
        t0 = time.perf_counter()
        res = run_case(truth, ranges, args.runs, args.points, scale, seed0)
        results[name] = res
        ratio = res["e_auto"] / res["e_glob"]
        p = np.percentile(ratio, [50, 90, 95, 100])
        alt = res["fit_old"] & (res["lr"] > np.log(res["k"]))
        found = f"{100 * np.mean(res['found']):6.0f}%" if scale is not None else f"{'-':>7}"
        differ = res["fit_old"]
        nearer = (
            f"{np.sum(res['e_old'][differ] < res['e_glob'][differ]):3d}/{np.sum(differ):<3d}"
            if np.any(differ)
            else "   -   "
        )
        print(
            f"{name:<32}{100 * np.mean(res['fit']):6.0f}%{100 * np.mean(res['fit_old']):5.0f}"
            f"%{100 * np.mean(alt):5.0f}%{found}"
            f" | {'':>22}{p[0]:5.2f} {p[1]:5.2f} {p[2]:5.2f} {p[3]:5.2f} {100 * np.mean(ratio <= 1.5):4.0f}% |"
            f" {1e6 * np.sqrt(np.mean(res['e_auto'] ** 2)):12.1f}{1e6 * np.sqrt(np.mean(res['e_glob'] ** 2)):7.1f}"
            f"{1e6 * np.sqrt(np.mean(res['e_old'] ** 2)):6.1f}"
            f" | {nearer:>13}  {agreement(res, res['fit']):>12}  {agreement(res, alt)}  "
            f" ({time.perf_counter() - t0:.0f} s)"
        )
    print("\nSigma honesty (mean reported sigma / RMS error about the truth, per DH parameter that varies):")
    for name in results:
        if "exact" in name:
            for label, fit in (("auto", ""), ("global", "_g")):
                med, lo, hi, share, off = honesty(results[name], fit)
                print(
                    f"  {name:<30} {label:<7} median {med:.2f}, range {lo:.2f}-{hi:.2f}, {100 * share:.0f}% within"
                    " 0.8-1.25" + (f"; outside: {off}" if off else "")
                )
    if args.save:
        np.savez(args.save, **{f"{i}_{k}": v for i, res in enumerate(results.values()) for k, v in res.items()})
    t_a = np.concatenate([r["t_auto"] for r in results.values()])
    t_g = np.concatenate([r["t_glob"] for r in results.values()])
    print(f"\nTime per identify (median): auto {1e3 * np.median(t_a):.0f} ms, global {1e3 * np.median(t_g):.0f} ms")


if __name__ == "__main__":
    main()
