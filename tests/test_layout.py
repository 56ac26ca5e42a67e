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
    # no cycle: a depth-first search meets no module still on its path
    state = {}

    def visit(m, path):
        state[m] = "open"
        for n in sorted(graph.get(m, ())):
            assert state.get(n) != "open", f"a cycle among the core's modules: {' -> '.join([*path, m, n])}"
            if n not in state:
                visit(n, [*path, m])
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [])


def test_no_rust_source_file_is_over_800_lines():
    """Files split by concern (issue 35): none longer than 800 lines."""
    long = {
        str(p.relative_to(ROOT)): n
        for p in (ROOT / "crates").rglob("*.rs")
        if "target" not in p.parts and (n := len(p.read_text().splitlines())) > 800
    }
    assert not long, long
