"""Every command's `--json` document is SI and every number in it has a unit known from its key (docs/cli.md,
"--json [PATH]"): the key ends with its unit (`_m`, `_rad`, ...), or it falls under one of the documented rules
(joint vectors, 4x4 poses, parameter-table rows, rows that name their unit, unitless counts and ratios). A key
that follows none of them (`rms`, `radius`, `arc_deg`) fails, naming the command and the key's path."""

import json

import numpy as np
import pytest

import denavit as dv
from cli import run

SUFFIXES = ("_m", "_rad", "_m3", "_s", "_m_s2", "_si")
JOINT_VECTORS = {"q", "qd", "qdd", "home", "offsets", "lower", "upper", "tau", "tau_gravity", "f_ext"}
POSES = {"placements"}
TABLE_COLUMNS = {"d", "theta", "a", "alpha", "b", "c", "wx", "wy", "wz", "vx", "vy", "vz"}
UNIT_ROW = {"nominal", "value", "sigma", "prior_sigma"}
UNITLESS = {
    "n_poses",
    "n_points",
    "n_train",
    "n_test",
    "positions",
    "flagged",
    "iterations",
    "restarts",
    "evaluations",
    "rank",
    "joints",
    "joint",
    "outliers",
    "selected",
    "direction",
    "normal",
    "orientation",
    "condition_number",
    "observability",
    "correlation",
    "combination",
    "reading_scale",
    "n_free",
    "effective_parameters",
}


def numeric(x) -> bool:
    return (isinstance(x, (int, float)) and not isinstance(x, bool)) or (
        isinstance(x, list) and bool(x) and all(numeric(v) or v is None for v in x)
    )


def flat(x) -> bool:
    return isinstance(x, dict) and all(numeric(v) or v is None for v in x.values())


def offenders(doc, path="", parent=None) -> list[str]:
    """The paths of numbers whose unit no rule gives. ``parent``: the dict holding the value (for the row rules)."""
    bad = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            p = f"{path}.{k}"
            if k.startswith(("T_", "R_")) or k in POSES or (k in UNITLESS and (numeric(v) or flat(v))):
                # poses (a dict of poses by joint name included); unitless numbers, or a flat dict of them
                # (observability, combination)
                continue
            if numeric(v):
                ok = (
                    k.endswith(SUFFIXES)
                    or k in JOINT_VECTORS
                    or ("joint" in doc and (k in TABLE_COLUMNS or k.removesuffix("_sigma") in TABLE_COLUMNS))
                    or ("unit" in doc and k in UNIT_ROW)
                )
                if not ok:
                    bad.append(p)
            else:
                bad += offenders(v, p, doc)
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            bad += offenders(v, f"{path}[{i}]", parent)
    return bad


def test_the_rules_catch_unsuffixed_keys():
    """The walker itself: an unsuffixed or degree key is caught; the rules let the documented ones pass."""
    assert offenders({"rms": 1.0, "joints": [{"joint": "A1", "arc_deg": 3.0, "radius": 2.0, "d": 0.1}]}) == [
        ".rms",
        ".joints[0].arc_deg",
        ".joints[0].radius",
    ]
    assert (
        offenders(
            {
                "parameters": [{"name": "a_1", "unit": "m", "value": 0.18, "sigma": None}],
                "rms_m": 1e-5,
                "q": [0.1],
                "T_world_tool": [[1.0]],
            }
        )
        == []
    )
    assert offenders({"rows": [{"alpha": 1.0}]}) == [".rows[0].alpha"]  # table columns only in rows of a joint


@pytest.fixture(scope="module")
def documents(tmp_path_factory):
    """The --json document of every command that has one, on the KR5 (identify in each convention)."""
    from denavit import calibration as cal

    tmp = tmp_path_factory.mktemp("json")
    kr5 = dv.load_robot("kr5")
    meas = cal.simulate(kr5, cal.configurations(kr5, 40), tool=(0.05, 0.03, 0.1), noise=2e-5, seed=3)
    (tmp / "m.csv").write_text(
        "# units: length=m angle=rad\nq1,q2,q3,q4,q5,q6,x,y,z\n"
        + "".join(",".join(repr(float(v)) for v in [*q, *p]) + "\n" for q, p in zip(meas.q, meas.points, strict=True))
    )
    q = np.radians([[90, -80, 100, 10, 70, 5], [80, -95, 85, -5, 95, 10], [100, -85, 95, 0, 80, -10]])
    (tmp / "t.csv").write_text(
        "# units: length=m angle=rad\nq1,q2,q3,q4,q5,q6\n"
        + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in q)
    )

    def doc(*args):
        p = run(*args, "--json", ok=False)
        assert p.returncode in (0, 1), p.stderr
        return json.loads(p.stdout)

    docs = {
        "models": doc("models"),
        "show": doc("show", "kr5"),
        "export": doc("export", "kr5"),
        "fk": doc("fk", "kr5", "--q", "10,20,30,40,50,60"),
        "ik": doc("ik", "kr5", "--pose", "800,0,1000,0,180,0"),
        "dynamics": doc("dynamics", "puma560", "--q", "10,20,30,40,50,60", "--f-ext", "1,2,3,0.1,0.2,0.3"),
        "plan": doc("plan", "kr5"),
    }
    for conv in ("dh", "mdh", "edh", "poe"):
        docs[f"convert {conv}"] = doc("convert", "kr5", "--to", conv)
        docs[f"identify {conv}"] = doc(
            "identify",
            "--example",
            "kr5",
            "--convention",
            conv,
            *(("--save", tmp / "id.toml") if conv == "edh" else ()),
        )  # edh: the covariance is saved with it
    docs["calibrate"] = doc("calibrate", tmp / "m.csv", "--nominal", "kr5", "--tool", "50,30,100")
    docs["compensate"] = doc("compensate", tmp / "t.csv", "--nominal", "kr5", "--identified", tmp / "id.toml")
    return docs


def test_every_number_in_every_command_json_has_a_unit_from_its_key(documents):
    assert (
        "predicted_after" in documents["compensate"]
    )  # the identified file carries its covariance: the per-row sigmas are there
    for name, d in documents.items():
        assert offenders(d) == [], name
        if isinstance(d, dict):
            assert d["units"]["length"] == "m" and d["units"]["angle"] == "rad", name


def test_identify_json_is_si_whatever_the_units_printed(documents):
    """The KR5 example: the joint axes' numbers in m and rad (a 600 mm upper arm is 0.6, a 30-90 degree arc below
    pi)."""
    d = documents["identify dh"]
    a2 = next(r for r in d["parameters"] if r["joint"] == "A2")
    assert a2["a"] == pytest.approx(0.6, abs=1e-3)  # Hayat Table III: a2 = 600 mm
    for j in d["joints"]:
        assert 0 < j["arc_rad"] < np.pi and j["residuals"]["rms_m"] < 1e-4 and j["axis"]["sigma_point_perp_m"] < 1e-3
        assert j["circle"]["radius_m"] is None or j["circle"]["radius_m"] < 2.0
    assert d["rms_m"] < 1e-4 and d["bounding_box"]["volume_m3"] < 2.0


def test_a_document_on_standard_output_is_alone_there(tmp_path):
    """``--save -`` (a robot file) and ``-o -`` (a compensated program) leave standard output to that document:
    the tables, notes and ``wrote`` lines go to stderr (they had come first, so the TOML did not parse)."""
    import tomllib

    s = tmp_path / "s.csv"
    run("simulate", "kr5", "-o", s, "--points", "8", "--seed", "2")
    p = run("identify", s, "--nominal", "kr5", "--save", "-")
    doc = tomllib.loads(p.stdout)
    assert doc["name"] and len(doc["joints"]) == 6
    assert "wrote -" in p.stderr
