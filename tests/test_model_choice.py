"""calibrate chooses what to fit by cross-validated prediction, with plausible-size priors (issue 36):
denavit.calibration.selection and denavit.calibration.priors."""

import json
import math

import numpy as np
import pytest

import denavit as dv
from cli import run as run_cli
from denavit import calibration as cal
from denavit.io import results
from denavit.io.measurements import read_measurements, to_csv
from denavit.io.robots import as_robot

TOOL = np.array([0.05, 0.03, 0.10])
HOME = np.radians([0, -90, 90, 0, 45, 0])
FULL_FAMILY = {"full", "full-prior", "full-prior-no-beta", "full-prior-no-last"}


@pytest.fixture(scope="module")
def kr5():
    return as_robot("kr5")


def truth_with(kr5, seed, links: bool):
    """The KR5's ED-H chain with every joint offset moved (0.05 deg, one sigma) and, with ``links``, every link
    parameter too (0.5 mm, 0.05 deg)."""
    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    rng = np.random.default_rng(seed)
    x = pz.x0.copy()
    for c, name in enumerate(pz.names):
        if name.startswith(("base_", "tool_")):
            continue
        if name.startswith("offset_") or links:
            x[c] += rng.normal(0, 5e-4 if pz.units[c] == "length" else math.radians(0.05))
    return pz.model(x, "truth")


def poses(kr5, count, seed, half_deg=40):
    rng = np.random.default_rng(seed)
    return np.clip(HOME + rng.uniform(-1, 1, (count, 6)) * math.radians(half_deg), kr5.lower, kr5.upper)


def held_out(res, truth, q) -> float:
    """The RMS tool-position error (m) of a calibration at configurations q (exact truth points)."""
    p = cal.simulate(truth, q, tool=TOOL).points
    return float(np.sqrt(np.mean(np.sum((dv.fk_batch(res.model(), q)[:, :3, 3] - p) ** 2, axis=1))))


def test_auto_picks_offsets_when_the_links_are_nominal_and_predicts_as_well_as_the_best(kr5):
    """Only the joint offsets are off: the data hold nothing for the link parameters but noise. auto keeps the
    offsets model (13 free parameters, not 27), and on 150 held-out poses it predicts within 5 % of the best of the
    nested models fitted outright (full least squares overfits 30 poses)."""
    truth = truth_with(kr5, 1, links=False)
    meas = cal.simulate(truth, poses(kr5, 30, 2), tool=TOOL, noise=3e-5, seed=3)
    test = poses(kr5, 150, 4, half_deg=60)
    res = cal.calibrate(meas, kr5, tool=TOOL)
    assert res.model_choice.chosen == "offsets", res.model_choice.line()
    assert {c.name for c in res.model_choice.candidates} >= {"base-tool", "offsets", "full", "full-prior"}
    err = {
        m: held_out(cal.calibrate(meas, kr5, tool=TOOL, model=m), truth, test)
        for m in ("base-tool", "offsets", "full", "full-prior")
    }
    assert held_out(res, truth, test) <= 1.05 * min(err.values()), (held_out(res, truth, test), err)
    assert err["full"] > err["offsets"], err  # the choice matters: the full fit predicts worse


def test_auto_frees_the_links_when_they_are_off(kr5):
    """Every link parameter off by 0.5 mm / 0.05 deg: auto frees the link geometry (a model of the full family) and
    predicts held-out poses within 5 % of the best nested model, several times better than offsets alone."""
    truth = truth_with(kr5, 5, links=True)
    meas = cal.simulate(truth, poses(kr5, 30, 6), tool=TOOL, noise=3e-5, seed=7)
    test = poses(kr5, 150, 8, half_deg=60)
    res = cal.calibrate(meas, kr5, tool=TOOL)
    assert res.model_choice.chosen in FULL_FAMILY, res.model_choice.line()
    err = {
        m: held_out(cal.calibrate(meas, kr5, tool=TOOL, model=m), truth, test)
        for m in ("base-tool", "offsets", "full", "full-prior")
    }
    mine = held_out(res, truth, test)
    assert mine <= 1.05 * min(err.values()), (mine, err)
    assert mine < 0.3 * err["offsets"], (mine, err)


def test_priors_keep_a_barely_determined_last_link_near_nominal(kr5):
    """Joint 6 turns by +-2 deg only and the target sits 3.6 mm off its axis: the last link (alpha_5, a_5, b_5)
    is all but undetermined (least squares had swung it by millimetres to centimetres, sigmas of metres; now the
    parameters the data give sigmas beyond the plausible size of their errors are held as unidentifiable, and least
    squares still moves the rest by several prior widths). With the priors it stays within its prior width of the
    truth (the nominal), what the data cannot fix beyond the prior is held and listed, and every reported sigma
    includes the prior (none above its width)."""
    tool = np.array([0.003, 0.002, 0.06])
    rng = np.random.default_rng(5)
    q = HOME + rng.uniform(-1, 1, (25, 6)) * np.radians([30, 30, 30, 30, 30, 2])
    pz = cal.parametrize(kr5, "edh", tool=tool)
    meas = cal.simulate(kr5, q, tool=tool, noise=5e-5, seed=1)  # the truth is the nominal
    last = [pz.index(n) for n in ("alpha_5", "a_5", "b_5")]
    ls = cal.calibrate(meas, kr5, tool=tool, model="full")
    # the data alone do not hold it: least squares moves it by more than 2 prior widths (0.1 deg, 1 mm); offset_5, which
    # they would give a sigma of hundreds of degrees (it had moved by 35 deg, a_5 by 35 mm), is unidentifiable
    widths = {"alpha_5": math.radians(0.1), "a_5": 1e-3, "b_5": 1e-3}
    assert max(abs(ls.values[k] - pz.x0[k]) / widths[pz.names[k]] for k in last) > 2
    assert ls.status[pz.index("offset_5")] == "unidentifiable"
    res = cal.calibrate(meas, kr5, tool=tool, model="full-prior")
    width = res.prior_sigma
    for k in last:
        assert abs(res.values[k] - pz.x0[k]) < width[k], (pz.names[k], res.values[k] - pz.x0[k])
    # held: beyond their prior ("fixed (prior)", in a note), or beyond the plausible size of their errors
    # ("unidentifiable", with the reason)
    held = [pz.names[k] for k in range(pz.n_params) if res.status[k] in ("fixed (prior)", "unidentifiable")]
    assert held and any(n in held for n in ("alpha_5", "a_5", "b_5", "offset_5"))
    why = {u.name: u.reason for u in res.identifiability.unidentifiable}
    for name in held:
        assert any(
            "beyond their prior" in n and name in n for n in res.notes
        ) or "beyond the plausible size" in why.get(name, ""), (name, res.notes, why)
    est = np.isfinite(res.sigma) & np.isfinite(width)
    assert np.all(res.sigma[est] <= width[est] * (1 + 1e-9)), [
        (pz.names[k], res.sigma[k], width[k]) for k in np.flatnonzero(est)
    ]
    doc = results.to_json(res)
    row = next(r for r in doc["parameters"] if r["name"] == "a_5")
    assert row["prior_sigma"] == pytest.approx(1e-3)


def test_hat_matrix_leave_one_out_equals_explicit_refits():
    """The deletion formula e_(i) = (I - H_ii)^-1 r_i against explicit refits without each pose's 3 rows, on a
    linear least squares with and without prior (ridge) rows; trace(H) is the sum of the blocks' traces."""
    from denavit.calibration.selection import loo_residuals

    rng = np.random.default_rng(0)
    n, k, p = 12, 3, 5
    J = rng.normal(size=(n * k, p))
    y = J @ rng.normal(size=p) + 0.1 * rng.normal(size=n * k)
    for P in (None, np.diag(rng.uniform(0.5, 2.0, p))):

        def fit(rows, P=P):
            A = J[rows] if P is None else np.vstack([J[rows], P])
            b = np.concatenate([y[rows], np.zeros(0 if P is None else p)])
            return np.linalg.lstsq(A, b, rcond=None)[0]

        beta = fit(np.arange(n * k))
        r = J @ beta - y
        E, dof = loo_residuals(J, r, k, P)
        for i in range(n):
            keep = np.array([j for j in range(n * k) if j // k != i])
            b_i = fit(keep)
            np.testing.assert_allclose(E[i], J[i * k : i * k + k] @ b_i - y[i * k : i * k + k], rtol=1e-9, atol=1e-12)
        G = J.T @ J + (0 if P is None else P.T @ P)
        assert dof == pytest.approx(np.trace(J @ np.linalg.solve(G, J.T)), rel=1e-9)


def test_hat_matrix_leave_one_out_matches_kinematic_refits(kr5):
    """On the kinematic (nonlinear) problem the formula is first order: each pose's leave-one-out error from the hat
    matrix agrees with a refit without that pose within 2 % (offsets model, 12 poses)."""
    from denavit.calibration import least_squares as ls

    truth = truth_with(kr5, 11, links=False)
    meas = cal.simulate(truth, poses(kr5, 12, 12), tool=TOOL, noise=3e-5, seed=13)
    res = cal.calibrate(meas, kr5, tool=TOOL, model="offsets")
    cand = res.model_choice.winner
    pz = res.parametrization
    w = ls.weights("point", 1e-5, 1e-5)
    for i in range(meas.n):
        others = meas.subset([j for j in range(meas.n) if j != i])
        x, _ = ls.fit_parameters(pz, cand.x, cand.free, others, w, "linear", None)
        pred = pz.evaluate(x, meas.q[i : i + 1], False)[0][0, :3, 3]
        assert cand.loo[i] == pytest.approx(np.linalg.norm(pred - meas.points[i]), rel=0.02)


def test_the_model_chosen_line_in_the_cli_json_and_repr(kr5, tmp_path):
    """One line says which model won and gives each candidate's cross-validated error: on the terminal, in the JSON
    (model_choice) and in the result's repr; --model picks one; --prior's grammar and its errors."""
    truth = truth_with(kr5, 21, links=True)
    f = tmp_path / "m.csv"
    f.write_text(to_csv(cal.simulate(truth, poses(kr5, 30, 22), tool=TOOL, noise=3e-5, seed=23), "mm", "deg"))
    out = tmp_path / "r.json"
    p = run_cli("calibrate", f, "--nominal", "kr5", "--tool", "50,30,100", "--holdout", "0", "--json", out, columns=400)
    lines = [ln for ln in p.stdout.splitlines() if "chosen by leave-one-pose-out" in ln]
    assert len(lines) == 1, p.stdout
    doc = json.loads(out.read_text())["model_choice"]
    names = [c["name"] for c in doc["candidates"]]
    assert doc["chosen"] in names and f"model {doc['chosen']} " in lines[0]
    for c in doc["candidates"]:
        assert c["name"] in lines[0] and c["cv_rms_m"] > 0
    res = cal.calibrate(read_measurements(f), kr5, tool=TOOL)
    assert "leave-one-out rms" in repr(res) and res.model_choice.chosen in repr(res)
    p = run_cli(
        "calibrate",
        f,
        "--nominal",
        "kr5",
        "--tool",
        "50,30,100",
        "--holdout",
        "0",
        "--model",
        "full",
        "--prior",
        "length=2mm, angle=0.05deg",
    )
    assert "model full as asked" in p.stdout
    p = run_cli("calibrate", f, "--nominal", "kr5", "--prior", "length=2deg", ok=False)
    assert p.returncode == 2 and "length is a length" in p.stderr.strip().splitlines()[-1]


def test_prior_grammar_and_python_forms(kr5):
    """--prior's text and the Python dict give SI widths by kind and by parameter; 'none' is no prior."""
    from denavit.calibration.priors import DEFAULT_WIDTHS, as_prior, parse_prior

    pr = parse_prior("length=2mm, angle=0.05deg, offset=30arcsec, scale=50ppm, a_5=3")
    assert pr.widths == pytest.approx(
        {"length": 2e-3, "angle": math.radians(0.05), "offset": math.radians(30 / 3600), "scale": 5e-5}
    )
    pz = cal.parametrize(kr5, "edh", tool=TOOL)
    s = pr.sigma(pz)
    assert (
        s[pz.index("a_5")] == pytest.approx(3e-3) and s[pz.index("a_4")] == 2e-3
    )  # a bare number in --length (mm) and np.isinf(s[pz.index("base_tx")]) and np.isinf(s[pz.index("tool_z")])
    assert parse_prior("none") is None and as_prior(False) is None
    assert as_prior({"length": 5e-4}).widths["angle"] == DEFAULT_WIDTHS["angle"]
    with pytest.raises(dv.DenavitError, match="matches no parameter"):
        as_prior({"nonsense_*": 1e-3}).sigma(pz)
    with pytest.raises(dv.DenavitError, match="model: expected one of"):
        cal.calibrate(cal.simulate(kr5, poses(kr5, 20, 1), tool=TOOL), kr5, tool=TOOL, model="everything")
