"""The layout's promises (issue 11): conventions live in the core only, one edge layer for units and files."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = [
    p
    for p in ROOT.rglob("*")
    if p.suffix in (".py", ".rs", ".md") and "target" not in p.parts and ".git" not in p.parts
]

# the factor orders of DH, MDH and ED-H links as docs/conventions.md writes them
FACTOR_ORDERS = [
    r"Rz\(theta ?\+ ?q\) Tz\(d\)",
    r"Tz\(d\) Tx\(a\) Rx\(alpha\)",
    r"Rx\(alpha\) Tx\(a\) Rz\(theta",
    r"Rx\(alpha\) Trans\(a, b, c\)",
    r"Rx\(alpha\) Tx\(a\) Ty\(b\) Tz\(c\)",
    r"Rx\(alpha_\{i-1\}\) Tx\(a_\{i-1\}\)",
]


def test_factor_orders_are_written_in_the_core_and_the_docs_only():
    found = {
        str(p.relative_to(ROOT))
        for p in SOURCES
        for pat in FACTOR_ORDERS
        if re.search(pat, p.read_text(errors="ignore"))
    }
    assert found == {"crates/denavit-core/src/convention.rs", "docs/conventions.md"}, found


def test_units_are_parsed_in_the_edge_layer_only():
    """One '# units:' parser and one table of unit scales (denavit.io.units); no module keeps its own."""
    pkg = ROOT / "python" / "denavit"
    for p in pkg.rglob("*.py"):
        text = p.read_text()
        rel = str(p.relative_to(pkg))
        if rel != "io/units.py":
            assert not re.search(r"units\s*\\?s\*:", text) and "_units_comment" not in text, rel
            assert not re.search(r'\{"m": 1\.0, "mm": 1e-3', text), rel


def _core_module_graph():
    """The core's top-level modules (files or folders under crates/denavit-core/src) and the modules each one's
    code names (`crate::name`), comments and docs left out."""
    src = ROOT / "crates" / "denavit-core" / "src"
    graph = {}
    for p in src.rglob("*.rs"):
        module = p.relative_to(src).parts[0].removesuffix(".rs")
        if module == "lib":
            continue
        names = graph.setdefault(module, set())
        for line in p.read_text().splitlines():
            code = line.split("//")[0]
            names.update(m for m in re.findall(r"\bcrate::([a-z_]+)", code) if m != module)
    return graph


def _assert_acyclic(graph: dict, what: str) -> None:
    """No cycle in ``graph`` ({node: the nodes it names}): a depth-first search meets no node still on its path."""
    state: dict = {}

    def visit(m, path):
        state[m] = "open"
        for n in sorted(graph.get(m, ())):
            assert state.get(n) != "open", f"a cycle among {what}: {' -> '.join([*path, m, n])}"
            if n not in state:
                visit(n, [*path, m])
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [])


def test_the_cores_modules_are_layered_without_cycles():
    """pinocchio's layering (issue 35): spatial types (with the link inertia) at the bottom, then the model, which
    depends on no algorithm, then the algorithms; no module reaches, directly or not, back to itself."""
    graph = _core_module_graph()
    modules = set(graph) - {"builtin_planar"}
    assert {"spatial", "inertia", "model", "kinematics", "ik", "dynamics", "axes", "convention", "extract"} <= modules
    # the bottom and the model name nothing above them
    assert graph["spatial"] <= {"error"}
    assert graph["inertia"] <= {"error", "spatial"}
    assert graph["model"] <= {"error", "spatial", "inertia"}, graph["model"]
    _assert_acyclic(graph, "the core's modules")


def test_no_rust_source_file_is_over_800_lines():
    """Files split by concern (issue 35): none longer than 800 lines."""
    long = {
        str(p.relative_to(ROOT)): n
        for p in (ROOT / "crates").rglob("*.rs")
        if "target" not in p.parts and (n := len(p.read_text().splitlines())) > 800
    }
    assert not long, long


#: The Python package's layers, lowest first (issue 35): a module imports from its own layer or lower ones only.
#: The core and the bottom; the domain (models, fits, calibration, compensation: objects in, objects out); the edge
#: (io/: every file, format and unit); what presents results (reports, figures); the front door (api); fleets of
#: jobs on the api; the command line on top. The package's own ``__init__`` (lazy names) stands outside.
PY_LAYERS = [
    ("_core", "errors", "geometry", "message", "progress", "data", "models"),
    (
        "robot",
        "limits",
        "sweeps",
        "fitting",
        "identification",
        "calibration",
        "compensation",
        "accuracy",
        "conversion",
        "recording",
    ),
    ("io",),
    ("report", "plotting"),
    ("api",),
    ("fleet",),
    ("cli", "__main__"),
]


def _python_import_graph() -> dict:
    """{module: the package's modules it imports} over python/denavit, lazy imports inside functions included and
    ``if TYPE_CHECKING:`` blocks (annotations only) left out."""
    import ast

    pkg = ROOT / "python" / "denavit"

    def name(p: Path) -> str:
        parts = ["denavit", *p.relative_to(pkg).with_suffix("").parts]
        return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)

    files = {name(p): p for p in pkg.rglob("*.py")}
    modules = set(files) | {"denavit._core"}
    graph = {"denavit._core": set()}
    for mod, p in files.items():
        tree = ast.parse(p.read_text())
        typing_only = {
            id(k)
            for n in ast.walk(tree)
            if isinstance(n, ast.If) and "TYPE_CHECKING" in ast.unparse(n.test)
            for b in n.body
            for k in ast.walk(b)
        }
        base = mod if p.name == "__init__.py" else mod.rsplit(".", 1)[0]
        deps = set()
        for n in ast.walk(tree):
            if id(n) in typing_only:
                continue
            if isinstance(n, ast.ImportFrom):
                if n.level:
                    up = base.split(".")[: len(base.split(".")) - (n.level - 1)]
                    src = ".".join(up + ([n.module] if n.module else []))
                else:
                    src = n.module or ""
                for a in n.names:
                    if f"{src}.{a.name}" in modules:
                        deps.add(f"{src}.{a.name}")
                    elif src in modules:
                        deps.add(src)
            elif isinstance(n, ast.Import):
                deps.update(a.name for a in n.names if a.name in modules)
        graph[mod] = deps - {mod}
    return graph


def _py_layer(mod: str) -> int | None:
    top = mod.split(".")[1] if "." in mod else None
    return next((i for i, names in enumerate(PY_LAYERS) if top in names), None)


def test_the_python_modules_are_layered_without_cycles():
    """Issue 35: no import cycle among python/denavit's modules, and no upward edge (a domain module importing io/,
    the api or the command line; io/ importing a report; ...); a new module must find its layer here."""
    graph = _python_import_graph()
    unplaced = sorted(m for m in graph if m != "denavit" and _py_layer(m) is None)
    assert not unplaced, f"modules in no layer of PY_LAYERS: {unplaced}"
    upward = sorted(
        f"{m} -> {d}"
        for m, ds in graph.items()
        if m != "denavit"
        for d in ds
        if d != "denavit" and _py_layer(d) > _py_layer(m)
    )
    assert not upward, upward
    _assert_acyclic(graph, "python/denavit's modules")


def test_no_python_source_file_is_over_800_lines_nor_function_over_150():
    """Files split by concern and functions short (issue 35): in python/denavit, tests and benchmarks no file over
    800 lines; in python/denavit no function over 150 lines (a nested function counted in its parent's)."""
    import ast

    files = [
        p
        for d in ("python/denavit", "tests", "benchmarks")
        for p in (ROOT / d).rglob("*.py")
        if "target" not in p.parts
    ]
    long_files = {str(p.relative_to(ROOT)): n for p in files if (n := len(p.read_text().splitlines())) > 800}
    assert not long_files, long_files
    long_functions = {
        f"{p.relative_to(ROOT)}:{n.lineno} {n.name}": n.end_lineno - n.lineno + 1
        for p in (ROOT / "python" / "denavit").rglob("*.py")
        for n in ast.walk(ast.parse(p.read_text()))
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.end_lineno - n.lineno + 1 > 150
    }
    assert not long_functions, long_functions
