"""identify's ``auto`` fits the joints' reading scales only where the evidence shows them (issue 36).

The issue's reproduction: the UR5 swept 30 degrees per joint about an unusual home, 50 points per sweep, 0.02 mm
noise, exact readings. auto had fitted reading scales in 4 of 6 seeds (any positive median-unbiased spread of the
free scale estimates fitted them: about every other run) and put the axes 77-300 um from the truth instead of
28-31 um. benchmarks/bench_identify_choice.py, 100 seeds per case, after the change: scales fitted in 1 % of runs
on exact readings (the old rule: 49 %), auto's axes within 1.5x of the exact-scale global fit's in 99 %; 200 ppm
scale errors on joints 2 and 3 fitted in every run on 90 degree arcs, the axes there 0.26x (median; at most 0.50x)
the exact-scale fit's error.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import denavit as dv
from denavit import sweeps as sw

ident = importlib.import_module("denavit.identification.choice")

HOME = np.radians([10.79, 44.5, 36.14, -1.70, 3.45, 42.87])
RANGES30 = np.radians(
    np.array([-4.2, 25.8, 29.5, 59.5, 21.1, 51.1, -16.7, 13.3, -11.5, 18.5, 27.9, 57.9]).reshape(6, 2)
)
TOOL = (0.03, 0.02, 0.10)


@pytest.fixture(scope="module")
def truth():
    m = dv.load_robot("ur5").model()
    T = np.eye(4)
    T[:3, 3] = TOOL
    return dv.axes(m, HOME), dv.fk(m.with_tool(T), HOME)[:3, 3]


def axis_error(res, truth) -> float:
    """RMS over the joints of the distance of the true circle centre from the identified line (m)."""
    ax, p = truth
    e = []
    for j in range(6):
        n_t, n_i = ax.directions[j], res.axes.directions[j]
        c = ax.points[j] + n_t * ((p - ax.points[j]) @ n_t)
        r = c - res.axes.points[j]
        e.append(np.linalg.norm(r - n_i * (r @ n_i)))
    return float(np.sqrt(np.mean(np.square(e))))


def sweeps(ranges, seed, scale=None):
    s = dv.simulate("ur5", home=HOME, ranges=ranges, points_per_sweep=50, noise=2e-5, tool_point=TOOL, seed=seed)
    if scale is None:
        return s
    return sw.SweepSet(
        [sw.Sweep(x.joint, x.points, HOME + (x.q - HOME) / (1 + scale), x.where) for x in s.sweeps],
        6,
        s.home,
        s.kinds,
        s.source,
        s.units,
    )


def test_exact_readings_on_short_arcs_get_no_reading_scales(truth):
    """Exact readings, the issue's 30 degree protocol, 8 seeds (0-7; before: scales fitted on seeds 0, 2, 3, 4, the
    axes there 1.06-9.9x the exact-scale fit's error). The 100-seed figures (1 % fitted, 99 % within 1.5x) allow one
    seed of eight: seed 4, whose free scale estimates scatter at 1-in-1000 odds (joint 2 at 3.2 sigma), is it."""
    fitted, ratios = [], []
    for seed in range(8):
        s = sweeps(RANGES30, seed)
        res = dv.identify(s, nominal="ur5")
        assert res.method == "global", (seed, res.notes)
        fitted.append(res.reading_scale is not None)
        if not fitted[-1]:  # the exact-scale global fit itself (its axes compared once)
            assert any(
                n.startswith(
                    "auto: no reading scale errors fitted (the evidence does not show them: 2 ln(marginal likelihood"
                    " ratio)"
                )
                for n in res.notes
            ), res.notes
            if seed:
                ratios.append(1.0)
                continue
        ref = dv.identify(s, nominal="ur5", method="global")
        ratios.append(axis_error(res, truth) / axis_error(ref, truth))
        if not fitted[-1]:
            assert ratios[-1] == pytest.approx(1.0, abs=1e-9)
    assert sum(fitted) <= 1, (fitted, ratios)
    assert sum(r <= 1.5 for r in ratios) >= 7, ratios


def test_real_scale_errors_are_still_found_where_the_arcs_show_them(truth):
    """200 ppm scale errors on joints 2 and 3 (each turns 1.0002 times its reading's motion), 90 degree arcs (home
    +-45 deg), where the free scales' sigmas are 20-60 ppm: auto fits the scales, with a note giving the evidence,
    joints 2 and 3 within 4 sigma of 200 ppm, and its axes nearer the truth than the exact-scale fit's (100 seeds:
    0.26x median, at most 0.50x)."""
    scale = np.zeros(6)
    scale[[1, 2]] = 2e-4
    ranges = np.stack([HOME - np.radians(45), HOME + np.radians(45)], axis=1)
    for seed in range(2):
        s = sweeps(ranges, seed, scale)
        res = dv.identify(s, nominal="ur5")
        ref = dv.identify(s, nominal="ur5", method="global")
        assert res.reading_scale is not None, res.notes
        assert any(
            n.startswith("auto: the readings' scale errors fitted (the evidence shows them") for n in res.notes
        ), res.notes
        sig = np.array([f.scale_sigma for f in res.fits])
        assert np.all(np.abs(res.reading_scale[[1, 2]] - 2e-4) < 4 * sig[[1, 2]]), (res.reading_scale, sig)
        assert axis_error(res, truth) < 0.75 * axis_error(ref, truth)


def test_scale_evidence_is_the_marginal_likelihood_ratio_at_its_maximum():
    """_scale_evidence: 2 ln of N(s; 0, C + tau^2 I) / N(s; 0, C) at its maximum over tau^2 >= 0, as a bounded
    scalar search of scipy finds it (C correlated, the estimates heteroscedastic); zero for estimates that scatter
    less than their covariance says."""
    optimize = pytest.importorskip("scipy.optimize")
    rng = np.random.default_rng(3)

    def loglik(s, V):  # ln N(s; 0, V) less its constant, by a Cholesky factor (not the eigenbasis the code uses)
        L = np.linalg.cholesky(V)
        z = np.linalg.solve(L, s)
        return -0.5 * (z @ z) - np.sum(np.log(np.diag(L)))

    positive = 0
    for _ in range(60):
        k = int(rng.integers(1, 8))
        A = rng.normal(size=(k, k)) * 10 ** rng.uniform(-5, -3, k)
        C = A @ A.T + np.diag(10 ** rng.uniform(-9, -7, k))
        s = rng.multivariate_normal(np.zeros(k), C + rng.uniform(0, 3) * np.mean(np.diag(C)) * np.eye(k))
        lr, t2 = ident._scale_evidence(s, C)

        def nll(lt, s=s, C=C, k=k):
            return -loglik(s, C + np.exp(lt) * np.eye(k))

        base = loglik(s, C)
        ev = np.linalg.eigvalsh(C)
        grid = np.linspace(np.log(1e-8 * ev.min()), np.log(1e3 * (ev.max() + s @ s)), 1000)
        best = grid[np.argmin([nll(x) for x in grid])]
        ref = optimize.minimize_scalar(
            nll, bounds=(best - 0.05, best + 0.05), method="bounded", options={"xatol": 1e-10}
        )
        ref_lr = max(2 * (-ref.fun - base), 0.0)
        assert lr == pytest.approx(ref_lr, abs=1e-6), (k, lr, ref_lr)
        if ref_lr > 1e-3:
            assert t2 == pytest.approx(np.exp(ref.x), rel=1e-3)
            positive += 1
    assert positive > 15
    assert ident._scale_evidence(np.zeros(3), np.eye(3) * 1e-8) == (0.0, 0.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_scale_errors_with_a_payload_declared_are_no_compliance(truth, seed):
    """200 ppm scale errors on joints 2 and 3 of a rigid UR5, 90 degree arcs, a 5 kg payload declared (the joints'
    compliance considered): the scales are found as without a payload, and no compliance is fitted in their place.
    Chosen first, each tested alone, the compliances had taken the scale errors' place (benchmarks/
    bench_identify_choice_poses.py: in 20 of 20 runs on points, scales found in none, the axes 1.22x the exact-scale
    fit's error); now each effect is tested with the others free (backward elimination)."""
    scale = np.zeros(6)
    scale[[1, 2]] = 2e-4
    ranges = np.stack([HOME - np.radians(45), HOME + np.radians(45)], axis=1)
    s = sweeps(ranges, seed, scale)
    res = dv.identify(s, nominal="ur5", payload=5.0)
    assert res.compliance is None, res.notes
    said = [n for n in res.notes if n.startswith("auto: no joint compliance fitted (BIC, Wald form: chi^2 ")]
    assert len(said) == 1 and "tested with the reading scales free" in said[0], res.notes
    assert res.reading_scale is not None, res.notes
    v = res.reading_scale[[1, 2]]
    assert np.all(np.abs(v - 2e-4) < np.abs(v)), v
    bare = dv.identify(s, nominal="ur5")  # (no payload: the scales' choice alone)
    np.testing.assert_allclose(res.reading_scale, bare.reading_scale, rtol=0, atol=1e-9)
    assert axis_error(res, truth) < 0.75 * axis_error(dv.identify(s, nominal="ur5", method="global"), truth)


@pytest.mark.parametrize("seed", [2, 3])
def test_a_drifting_home_with_a_payload_declared_is_no_compliance(seed):
    """The tool point moves N(0, 30 um) per coordinate between the sweeps of a rigid UR5 (exact readings, 90 degree
    arcs), a 5 kg payload declared: a home point per sweep, and no compliance beside it (seeds 2 and 3 had both, the
    compliances chosen first and alone: 13 of 20 runs in benchmarks/bench_identify_choice_poses.py)."""
    from dataclasses import replace

    ranges = np.stack([HOME - np.radians(45), HOME + np.radians(45)], axis=1)
    kw = {"home": HOME, "ranges": ranges, "points_per_sweep": 50, "noise": 2e-5, "seed": seed}
    d = np.random.default_rng(10_000 + seed).normal(0.0, 3e-5, (6, 3))
    s = dv.simulate("ur5", tool_point=TOOL, **kw)
    s = replace(s, sweeps=[dv.simulate("ur5", tool_point=np.add(TOOL, d[k]), **kw).sweeps[k] for k in range(6)])
    res = dv.identify(s, nominal="ur5", payload=5.0)
    assert res.method == "readings" and res.compliance is None and res.reading_scale is None, res.notes
    # (below its penalty, or every one fitted negative: tested in the fit with a home point per sweep)
    said = [n for n in res.notes if n.startswith("auto: no joint compliance fitted (")]
    assert len(said) == 1 and "tested with a home point per sweep free" in said[0], res.notes
