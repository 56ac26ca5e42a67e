import os

# pytest -n auto runs a test process per core: BLAS's own threads on top would oversubscribe the cores (a test of
# many small solves ran 10x slower beside another process); one BLAS thread per test process (before numpy loads)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import denavit as dv  # noqa: E402


@pytest.fixture(scope="session")
def kr5():
    return dv.load_robot("kr5")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# ------------------------------------------------------------------------------------------------ the HTML reports
# shared by tests/test_report.py and tests/test_report_browser.py; session-scoped so both files build them once


@pytest.fixture(scope="session")
def result():
    """A small simulated identification: KR5, Hayat's home and 90 degree ranges, 12 points per sweep, 20 um noise."""
    from denavit import sweeps as sw

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=12,
        noise=2e-5,
        seed=7,
    )
    return dv.identify(s, nominal=dv.load_robot("kr5"))


@pytest.fixture(scope="session")
def report_path(result, tmp_path_factory):
    from denavit import report as rep

    path = tmp_path_factory.mktemp("report") / "identification.html"
    rep.write_report(result, path)
    return path


@pytest.fixture(scope="session")
def model_report_path(tmp_path_factory):
    from denavit import report as rep

    path = tmp_path_factory.mktemp("model") / "tiansui.html"
    rep.write_model_report(dv.load_robot("tiansui_mdh"), path, compare="tiansui_edh")
    return path


@pytest.fixture(scope="session")
def calibrated():
    """A KR5 calibration from 60 simulated poses of a robot off its nominal (0.5 mm, 0.05 deg), 20 % held out:
    (the calibration, the true model, the poses' joint values)."""
    from denavit import calibration as cal

    kr5 = dv.load_robot("kr5")
    t = kr5.table
    E = np.random.default_rng(3).uniform(-1, 1, t.params.shape) * np.where(
        np.array(t.angle_columns), np.radians(0.05), 0.5e-3
    )
    true = dv.Table(t.convention, t.params + E, t.kinds, t.T_world_base, t.T_last_tool).to_model(
        "true", kr5.names, kr5.lower, kr5.upper
    )
    q = np.random.default_rng(5).uniform(kr5.lower, kr5.upper, (60, 6)) * 0.8
    return cal.calibrate(cal.simulate(true, q, noise=2e-5), kr5, holdout=0.2), true, q


@pytest.fixture(scope="session")
def every_report(result, calibrated, tmp_path_factory):
    """One report of each type: identify in each convention, show, calibrate, compensate (KR5, 6 joints)."""
    from denavit import compensation as cp
    from denavit import report as rep
    from denavit import sweeps as sw

    folder = tmp_path_factory.mktemp("every")
    kr5 = dv.load_robot("kr5")
    out = {}
    for conv in ("dh", "mdh", "edh", "poe"):
        out[f"identify-{conv}"] = folder / f"identify-{conv}.html"
        rep.write_report(dv.identify(result.sweeps, nominal=kr5, convention=conv), out[f"identify-{conv}"])
    out["show"] = folder / "show.html"
    rep.write_model_report(kr5, out["show"], q=np.radians(sw.PAPER_HOME_DEG))
    res, true, q = calibrated
    out["calibrate"] = rep.write_calibration_report(res, folder / "calibrate.html")
    c = cp.compensate(kr5.model(), true, dv.fk_batch(kr5.model(), q[:30]), q_nominal=q[:30])
    out["compensate"] = rep.write_compensation_report(
        c, kr5, res.robot(), folder / "compensate.html", source="program.csv"
    )
    return out
