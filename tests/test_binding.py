"""The binding `denavit._core` as a whole: nothing panics, errors carry the core's fields, every object pickles,
and the stub `_core.pyi` matches the module."""

import ast
import copy
import inspect
import pickle
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import denavit as dv
from denavit import _core

STUB = Path(dv.__file__).with_name("_core.pyi")
I4 = np.eye(4)


def planar(n=2):
    return dv.Table("dh", np.column_stack([np.zeros(n), np.zeros(n), np.full(n, 0.3), np.zeros(n)])).to_model("planar")


def public_callables():
    """Every public function of the module and every public method of its classes, as names."""
    names = set()
    for name, obj in vars(_core).items():
        if name.startswith("_"):
            continue
        if inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if not attr.startswith("_") and callable(member):
                    names.add(f"{name}.{attr}")
        elif callable(obj):
            names.add(name)
    return names


def zero_joint_calls():
    """One call of every public function and method on a 0-joint model, 0-size arrays and empty batches."""
    m = dv.Table("dh", np.zeros((0, 4))).to_model()
    z, zs = np.zeros(0), np.zeros((3, 0))
    t = dv.Table("dh", np.zeros((0, 4)))
    chain = _core.CalibrationChain([], [], [], np.zeros((0, 4, 4)), 0, 0, [])
    return {
        "fk": lambda: _core.fk(m, z),
        "joint_frames": lambda: _core.joint_frames(m, z),
        "jacobian": lambda: _core.jacobian(m, z),
        "fk_batch": lambda: _core.fk_batch(m, zs),
        "jacobian_batch": lambda: _core.jacobian_batch(m, zs),
        "axes": lambda: _core.axes(m, z),
        "extract": lambda: _core.extract(_core.axes(m, z), "dh"),
        "convention_info": lambda: _core.convention_info(""),
        "conventions": lambda: _core.conventions(),
        "default_limits": lambda: _core.default_limits(""),
        "rnea": lambda: _core.rnea(m, z, z, z),
        "bias_forces": lambda: _core.bias_forces(m, z, z),
        "gravity_torques": lambda: _core.gravity_torques(m, z),
        "mass_matrix": lambda: _core.mass_matrix(m, z),
        "coriolis_matrix": lambda: _core.coriolis_matrix(m, z, z),
        "forward_dynamics": lambda: _core.forward_dynamics(m, z, z, z),
        "kinetic_energy": lambda: _core.kinetic_energy(m, z, z),
        "potential_energy": lambda: _core.potential_energy(m, z),
        "rnea_batch": lambda: _core.rnea_batch(m, zs, zs, zs),
        "bias_forces_batch": lambda: _core.bias_forces_batch(m, zs, zs),
        "gravity_torques_batch": lambda: _core.gravity_torques_batch(m, zs),
        "mass_matrix_batch": lambda: _core.mass_matrix_batch(m, zs),
        "coriolis_matrix_batch": lambda: _core.coriolis_matrix_batch(m, zs, zs),
        "forward_dynamics_batch": lambda: _core.forward_dynamics_batch(m, zs, zs, zs),
        "transfer_inertias": lambda: _core.transfer_inertias(m, m),
        "ik": lambda: _core.ik(m, I4),
        "ik_path": lambda: _core.ik_path(m, np.zeros((0, 4, 4))),
        "ik_batch": lambda: _core.ik_batch(m, np.zeros((0, 4, 4))),
        "compensate": lambda: _core.compensate(m, m, np.zeros((0, 4, 4))),
        "parametrize": lambda: _core.parametrize(t, I4, I4),
        "Model.from_placements": lambda: _core.Model.from_placements(np.zeros((0, 4, 4)), []),
        "Model.with_base": lambda: m.with_base(I4),
        "Model.with_tool": lambda: m.with_tool(I4),
        "Model.with_inertias": lambda: m.with_inertias(z, np.zeros((0, 3)), np.zeros((0, 3, 3)), frame="world"),
        "Table.to_model": lambda: t.to_model("r", [], z, z),
        "Table.frames": lambda: t.frames(z),
        "Table.link_frames": lambda: t.link_frames(),
        "CalibrationChain.evaluate": lambda: chain.evaluate(z, zs),
    }


def test_zero_joints_and_empty_batches_never_panic():
    """Regression: `to_table` of a 0-joint model raised PanicException (the extraction indexed axis 0)."""
    calls = zero_joint_calls()
    assert set(calls) == public_callables(), "every public function and method has a 0-joint call here"
    for name, call in calls.items():
        try:
            call()
        except BaseException as e:  # noqa: BLE001 - PanicException derives from BaseException
            assert isinstance(e, dv.DenavitError), f"{name}: {type(e).__name__}: {e}"
    for conv in _core.conventions():
        m = dv.Table(conv, np.zeros((0, len(_core.convention_info(conv)["columns"])))).to_model()
        try:
            dv.to_table(m, conv)
        except BaseException as e:  # noqa: BLE001 - PanicException derives from BaseException
            assert isinstance(e, dv.DenavitError), f"to_table of a 0-joint model, {conv}: {type(e).__name__}: {e}"


BAD = [
    None,
    1.0,
    np.nan,
    "x",
    [[1, 2], [3]],
    np.zeros(0),
    np.zeros((0, 0)),
    np.zeros((2, 0)),
    np.full(2, np.nan),
    np.zeros((4, 4)),
    np.full((4, 4), np.inf),
    np.zeros((2, 3)),
    np.zeros((2, 3, 3)),
    np.zeros((2, 2, 2, 2)),
    np.zeros(6),
    [],
]


def bad_input_calls():
    m = planar().with_inertias(np.ones(2), np.zeros((2, 3)), np.tile(np.eye(3) * 0.01, (2, 1, 1)))
    q, qs, P = np.zeros(2), np.zeros((3, 2)), np.stack([I4, I4])
    return [
        (_core.fk, (m, q)),
        (_core.joint_frames, (m, q)),
        (_core.jacobian, (m, q)),
        (_core.fk_batch, (m, qs)),
        (_core.jacobian_batch, (m, qs)),
        (_core.axes, (m, q)),
        (_core.rnea, (m, q, q, q, np.zeros(3), np.zeros(6))),
        (_core.forward_dynamics, (m, q, q, q, np.zeros(3), np.zeros(6))),
        (_core.mass_matrix, (m, q)),
        (_core.rnea_batch, (m, qs, qs, qs, np.zeros(3), np.zeros((3, 6)))),
        (_core.coriolis_matrix_batch, (m, qs, qs)),
        (_core.transfer_inertias, (m, m, q)),
        (_core.ik, (m, I4, q)),
        (_core.ik_path, (m, P, q)),
        (_core.ik_batch, (m, P, qs[:2])),
        (_core.Model.from_placements, (P, ["revolute", "revolute"])),
        (dv.Table, ("dh", np.zeros((2, 4)), ["revolute"] * 2, I4, I4)),
        (m.with_inertias, (np.ones(2), np.zeros((2, 3)), np.tile(np.eye(3), (2, 1, 1)), "world", "origin", q)),
        (dv.JointAxes, (np.zeros((2, 3)), [[0, 0, 1.0], [0, 1, 0]])),
        (m.with_base, (I4,)),
        (_core.CalibrationChain, (["rz", "fixed"], [0, -1], [0, -1], I4[None], 1, 1, [-1])),
    ]


def test_bad_arguments_never_panic():
    """Each argument of each entry point replaced by ill-shaped, empty, non-finite or non-numeric values: a
    DenavitError (or a TypeError for a wrong Python type), never a panic. Regression: CalibrationChain with
    fixed of shape (2, 0) panicked (slice out of range)."""
    for f, args in bad_input_calls():
        for k in range(1 if isinstance(args[0], _core.Model) else 0, len(args)):
            for bad in BAD:
                a = list(args)
                a[k] = bad
                try:
                    f(*a)
                except BaseException as e:  # noqa: BLE001 - PanicException derives from BaseException
                    assert isinstance(e, (dv.DenavitError, TypeError)), (
                        f"{f.__name__} argument {k} = {bad!r}: {type(e).__name__}: {e}"
                    )
    with pytest.raises(dv.DenavitError, match=r"fixed: expected an array of shape \(N, 4, 4\), got shape \(2, 0\)"):
        _core.CalibrationChain(["fixed"], [0], [-1], np.zeros((2, 0)), 0, 0, [])
    with pytest.raises(dv.DenavitError, match="invalid n_params: expected an integer >= 0, got -1"):
        _core.CalibrationChain([], [], [], [], -1, 0, [])


def test_complex_arrays_are_refused_in_every_array_argument():
    """Regression: a complex array was cast to float64 (numpy drops the imaginary part with a ComplexWarning).
    Every array argument of every entry point now refuses it in one line naming the argument."""
    checked = 0
    for f, args in bad_input_calls():
        for k in range(1 if isinstance(args[0], _core.Model) else 0, len(args)):
            if not isinstance(args[k], np.ndarray):
                continue
            a = list(args)
            a[k] = args[k] + 1j
            with pytest.raises(
                dv.DenavitError,
                match=r"^invalid .*: expected an array-like of real floats, got a complex array \(dtype complex128\)$",
            ):
                f(*a)
            checked += 1
    assert checked >= 30


# ------------------------------------------------------------------------------------------------
# Structured errors
# ------------------------------------------------------------------------------------------------

FIELDS = (
    "what",
    "expected",
    "got",
    "index",
    "value",
    "reason",
    "iterations",
    "position_error",
    "rotation_error",
    "joint",
)


@pytest.mark.parametrize(
    "call, cls, kind, fields",
    [
        (lambda m: dv.fk(m, np.zeros(3)), dv.DenavitError, "SizeMismatch", {"what": "q", "expected": 2, "got": 3}),
        (lambda m: dv.fk(m, [0.0, np.inf]), dv.DenavitError, "NonFinite", {"what": "q", "index": 1, "value": np.inf}),
        (
            lambda m: m.with_tool(np.diag([1.0, 1, 1, 2])),
            dv.DenavitError,
            "NotSe3",
            {"what": "T_flange_tool", "reason": "last row must be [0, 0, 0, 1], got [0.0, 0.0, 0.0, 2.0]"},
        ),
        (
            lambda m: dv.jacobian(m, np.zeros(2), frame="flange"),
            dv.DenavitError,
            "InvalidArgument",
            {"what": "frame", "expected": "'local', 'local_world_aligned', 'world' or 'base'", "got": "'flange'"},
        ),
        (
            lambda m: dv.Table("hayati", np.zeros((1, 4))),
            dv.DenavitError,
            "UnknownName",
            {"what": "convention", "got": "hayati", "expected": "dh, mdh, edh, poe"},
        ),
        (
            lambda m: dv.JointAxes(np.zeros((1, 3)), [[0, 0, 0]]),
            dv.DegenerateError,
            "Degenerate",
            {"reason": "direction of axis 1 must be a non-zero direction, got length 0.000e0"},
        ),
        (
            lambda m: m.with_inertias([1.0, -1.0], np.zeros((2, 3)), np.zeros((2, 3, 3))),
            dv.DenavitError,
            "InvalidArgument",
            {"what": "mass of link 2", "expected": "a mass >= 0 kg", "got": "-1 kg", "joint": 2},
        ),
        (
            lambda m: m.with_inertias(np.ones(2), np.zeros((2, 3)), np.zeros((2, 3, 3)), q_ref=np.zeros(2)),
            dv.DenavitError,
            "InvalidArgument",
            {
                "what": "q_ref",
                "expected": "None with frame='link' (q_ref is the configuration of frame='world' inertias)",
                "got": "an array",
            },
        ),
        (
            lambda m: dv.extract(dv.axes(m, np.zeros(2)), "edh", origins=[[0, 0, 0], [0, np.nan, 0]]),
            dv.DenavitError,
            "NonFinite",
            {"what": "ED-H origin 2", "index": 1, "value": pytest.approx(np.nan, nan_ok=True)},
        ),
    ],
)
def test_core_errors_carry_their_fields(call, cls, kind, fields):
    with pytest.raises(cls) as e:
        call(planar())
    assert type(e.value) is cls and isinstance(e.value, ValueError)
    assert e.value.kind == kind
    for name in FIELDS:
        assert getattr(e.value, name) == fields.get(name), name


def test_not_converged_error_carries_iterations_and_errors():
    e = dv.NotConvergedError(
        "not converged", kind="NotConverged", iterations=7, position_error=1e-3, rotation_error=2e-3
    )
    assert (e.iterations, e.position_error, e.rotation_error, e.what) == (7, 1e-3, 2e-3, None)
    with pytest.raises(TypeError, match="unknown fields"):
        dv.DenavitError("x", colour="red")


def test_errors_pickle_with_their_fields():
    with pytest.raises(dv.DenavitError) as e:
        dv.fk(planar(), np.zeros(3))
    back = pickle.loads(pickle.dumps(e.value))
    assert type(back) is dv.DenavitError and str(back) == str(e.value)
    assert (back.kind, back.what, back.expected, back.got) == ("SizeMismatch", "q", 2, 3)


def test_with_inertias_is_a_method_of_the_binding():
    """Model.with_inertias / Model.inertias are #[pymethods] (not Python source run at import)."""
    assert inspect.ismethoddescriptor(vars(_core.Model)["with_inertias"])
    assert inspect.isdatadescriptor(vars(_core.Model)["inertias"]) and not isinstance(
        vars(_core.Model)["inertias"], property
    )
    assert (
        _core.Model.with_inertias.__text_signature__
        == '($self, masses, coms, inertias, frame="link", about="com", q_ref=None)'
    )


# ------------------------------------------------------------------------------------------------
# Objects that travel: pickle, deepcopy, other processes
# ------------------------------------------------------------------------------------------------


def state(x):
    """Every public property of a binding object, arrays as bytes (bit-for-bit comparison)."""
    if isinstance(x, (list, tuple)):
        return [state(v) for v in x]
    if isinstance(x, dict):
        return {k: state(v) for k, v in x.items()}
    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.shape, x.tobytes())
    if isinstance(x, float):
        return np.float64(x).tobytes()
    if type(x).__module__ == "denavit._core":
        props = [a for a, v in vars(type(x)).items() if not a.startswith("_") and not callable(v)]
        out = {a: state(getattr(x, a)) for a in props}
        if isinstance(x, _core.IkBatchResult):
            out["items"] = [state(r) for r in x]
        return (type(x).__name__, out)
    return x


def travelling_objects():
    """One object of every class of the binding, built as users build them."""
    kr5 = dv.load_model("kr5")
    heavy = kr5.with_inertias(
        np.linspace(1, 6, 6), np.full((6, 3), 0.01), np.tile(np.diag([0.02, 0.03, 0.04]), (6, 1, 1))
    )
    moved = heavy.with_base(dv.fk(kr5, np.full(6, 0.3))).with_tool(dv.fk(kr5, np.full(6, -0.2)))
    q = np.linspace(-0.5, 0.5, 6)
    ax = dv.axes(moved, q)
    targets = dv.fk_batch(kr5, np.random.default_rng(0).uniform(-1, 1, (3, 6)))
    chain = _core.CalibrationChain(
        ["rz", "tx", "fixed", "ry"], [0, 1, -1, 2], [0, -1, -1, 1], dv.fk(kr5, q)[None], 4, 2, [-1, 3]
    )
    ex = dv.extract(ax, "edh")
    return {
        "Model": heavy,
        "Model moved": moved,
        "Model bare": kr5,
        "Model 0 joints": dv.Table("dh", np.zeros((0, 4))).to_model(),
        "Table": ex.table,
        "Table poe": dv.extract(ax, "poe").table,
        "JointAxes": ax,
        "Extraction": ex,
        "PairDiagnostic": ex.pairs[1],
        "IkResult": dv.ik(kr5, targets[0]),
        "IkBatchResult": dv.ik_batch(kr5, targets),
        "IkBatchResult empty": dv.ik_batch(kr5, np.zeros((0, 4, 4))),
        "CalibrationChain": chain,
        "CalibrationChain parametrized": _core.parametrize(ex.table, I4, I4, "pose", True)["chain"],
        "Compensation": _core.compensate(kr5, kr5.with_base(dv.fk(kr5, np.full(6, 0.01))), targets, restarts=2),
    }


def behaviour(x):
    """What an object computes, beyond its properties."""
    if isinstance(x, _core.Model):
        q = np.linspace(-0.4, 0.7, x.nq)
        return [dv.fk(x, q), dv.jacobian(x, q), dv.rnea(x, q, q, q), dv.mass_matrix(x, q)]
    if isinstance(x, _core.CalibrationChain):
        rng = np.random.default_rng(3)
        return list(x.evaluate(rng.uniform(0.5, 1, x.n_params), rng.uniform(-1, 1, (2, x.nq))))
    if isinstance(x, _core.Table):
        return [x.to_model().placements, x.frames(np.full(len(x.kinds), 0.2))]
    return []


def test_every_class_is_covered_by_the_travel_tests():
    classes = {name for name, obj in vars(_core).items() if inspect.isclass(obj) and obj.__module__ == "denavit._core"}
    assert classes == {type(x).__name__ for x in travelling_objects().values()}


@pytest.mark.parametrize("how", ["pickle", "deepcopy", "copy"])
def test_objects_pickle_and_copy_bit_for_bit(how):
    """Regression: pickle.dumps(dv.load_model('kr5')) raised TypeError: cannot pickle 'denavit._core.Model'."""
    for name, x in travelling_objects().items():
        y = {"pickle": lambda v: pickle.loads(pickle.dumps(v)), "deepcopy": copy.deepcopy, "copy": copy.copy}[how](x)
        assert type(y) is type(x), name
        assert state(y) == state(x), name
        assert state(behaviour(y)) == state(behaviour(x)), name
        assert repr(y) == repr(x), name


def test_objects_travel_to_another_process():
    """The pickles load in a fresh interpreter (as multiprocessing's spawn, joblib or Dask do) and compute the same."""
    objects = travelling_objects()
    blob = pickle.dumps({name: (x, state(x), state(behaviour(x))) for name, x in objects.items()})
    code = (
        "import pickle, sys\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "import test_binding as t\n"
        "d = pickle.loads(sys.stdin.buffer.read())\n"
        "bad = [k for k, (x, s, b) in d.items() if t.state(x) != s or t.state(t.behaviour(x)) != b]\n"
        "print('bad:', bad)\n"
    )
    r = subprocess.run(
        [sys.executable, "-c", code, str(Path(__file__).parent)], input=blob, capture_output=True, check=False
    )
    assert r.returncode == 0, r.stderr.decode()
    assert r.stdout.decode().strip() == "bad: []"


# ------------------------------------------------------------------------------------------------
# The stub
# ------------------------------------------------------------------------------------------------


def stub_tree():
    """{name: (kind, params or None)} for the stub's module-level functions, classes and their members."""
    tree = ast.parse(STUB.read_text(encoding="utf-8"))
    out = {}

    def params(f):
        a = f.args
        return [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs] + ([f"*{a.vararg.arg}"] if a.vararg else [])

    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            out[node.name] = ("function", params(node))
        elif isinstance(node, ast.ClassDef):
            out[node.name] = ("class", None)
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    is_prop = any(isinstance(d, ast.Name) and d.id == "property" for d in item.decorator_list)
                    out[f"{node.name}.{item.name}"] = ("property", None) if is_prop else ("method", params(item))
                elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                    out[f"{node.name}.{item.target.id}"] = ("property", None)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out[node.target.id] = ("constant", None)
    return out


def text_params(obj):
    """Parameter names from __text_signature__ (None when there is none)."""
    sig = getattr(obj, "__text_signature__", None)
    if not sig:
        return None
    names = []
    for part in sig.strip("()").split(","):
        p = part.strip().split("=")[0].strip()
        if p and p not in ("/", "*", "$self", "$cls", "$type"):
            names.append(p.lstrip("$"))
    return names


def runtime_tree():
    out = {}
    for name, obj in vars(_core).items():
        if name.startswith("__") and name != "__version__":
            continue
        if inspect.isclass(obj):
            out[name] = ("class", None)
            for attr, member in vars(obj).items():
                if attr.startswith("_") and attr not in ("__init__", "__len__", "__getitem__", "__iter__"):
                    continue
                if attr == "__init__" or (attr == "__new__"):
                    continue
                if callable(member) and not inspect.isdatadescriptor(member):
                    out[f"{name}.{attr}"] = ("method", text_params(getattr(obj, attr)))
                else:
                    out[f"{name}.{attr}"] = ("property", None)
            if obj.__text_signature__:
                out[f"{name}.__init__"] = ("method", text_params(obj))
        elif callable(obj):
            out[name] = ("function", text_params(obj))
        else:
            out[name] = ("constant", None)
    return out


def test_stub_matches_the_module():
    """Every public function, class, method, property and constant of denavit._core is in _core.pyi and vice
    versa; parameter names match the runtime signatures."""
    stub, runtime = stub_tree(), runtime_tree()
    assert sorted(set(runtime) - set(stub)) == [], "in the module, missing from _core.pyi"
    assert sorted(set(stub) - set(runtime)) == [], "in _core.pyi, not in the module"
    for name, (kind, params) in runtime.items():
        skind, sparams = stub[name]
        assert skind == kind, f"{name}: {kind} in the module, {skind} in the stub"
        if params is not None:
            if kind == "method":
                sparams = [p for p in sparams if p not in ("self", "cls")]
            assert sparams == params, f"{name}: stub parameters {sparams}, runtime {params}"


# ------------------------------------------------------------------------------------------------
# Arrays for arrays, short reprs with the key numbers
# ------------------------------------------------------------------------------------------------


def test_numeric_list_properties_are_arrays():
    """Regression (issue 17): Model.lower / upper / offsets and JointAxes.q_ref / lower / upper were lists."""
    m = dv.load_model("kr5")
    ax = dv.axes(m, np.zeros(6))
    for x in (m.lower, m.upper, m.offsets, ax.q_ref, ax.lower, ax.upper):
        assert isinstance(x, np.ndarray) and x.dtype == np.float64 and x.shape == (6,)
    np.testing.assert_allclose(np.degrees(m.lower[:2]), [-155, -180])  # the KR5 robot file's limits


def test_table_repr_prints_its_rows_with_units():
    """Regression (issue 17): repr(Table) showed no values. Rows in mm and deg as the CLI prints them."""
    t = dv.Table("dh", [[0.4, 0.0, 0.18, np.pi / 2], [0.0, -np.pi / 2, 0.6, 0.0]], ["revolute", "prismatic"])
    lines = repr(t).splitlines()
    assert lines[0] == "Table('dh', 2 joints)"
    assert lines[1].split() == ["joint", "kind", "d", "[mm]", "theta", "[deg]", "a", "[mm]", "alpha", "[deg]"]
    assert lines[2].split() == ["1", "R", "400.000", "0.000", "180.000", "90.000"]
    assert lines[3].split() == ["2", "P", "0.000", "-90.000", "600.000", "0.000"]
    poe = repr(dv.to_table(t.to_model(), "poe").table).splitlines()[1].split()
    assert poe[2:5] == ["wx", "wy", "wz"] and poe[5:7] == ["vx", "[mm]"]  # screw directions are unitless


def test_model_repr_is_short_with_key_numbers():
    m = dv.load_model("kr5")
    # at q = 0 (KUKA's zero: upper arm horizontal, forearm in line) the wrist is 180 + 600 + 620 mm out, 400 + 120 mm up
    assert repr(m) == "Model('kr5', 6 joints RRRRRR, tool at [1400.0, 0.0, 520.0] mm at q = 0)"
    heavy = m.with_inertias(np.full(6, 2.0), np.zeros((6, 3)), np.tile(np.eye(3) * 0.01, (6, 1, 1)))
    assert repr(heavy).endswith(", 12.0000 kg)")


def test_calibration_chain_evaluate_refuses_a_bad_selection_in_one_line():
    """rows, columns and weights of CalibrationChain.evaluate: each bad value is a DenavitError that names it."""
    from denavit.calibration import parametrize

    chain = parametrize(dv.load_model("kr5"), "edh").chain
    x, qs = parametrize(dv.load_model("kr5"), "edh").x0, np.zeros((3, 6))
    for kw, what in (
        ({"rows": 0}, "rows"),
        ({"rows": 7}, "rows"),
        ({"columns": [-1]}, "columns[0]"),
        ({"columns": [2, 2]}, "each parameter at most once"),
        ({"columns": [chain.n_params]}, f"parameter indices below {chain.n_params}"),
        ({"rows": 3, "weights": [1.0, 2.0]}, "weights"),
        ({"rows": 3, "weights": [1.0, np.nan, 2.0]}, "weights"),
    ):
        with pytest.raises(dv.DenavitError, match=re.escape(what)) as e:
            chain.evaluate(x, qs, True, **kw)
        assert "\n" not in str(e.value)
    poses, J = chain.evaluate(x, qs, True, rows=3, columns=[5, 0], weights=[2.0, 2.0, 2.0])
    assert J.shape == (3, 3, 2) and poses.shape == (3, 4, 4)
