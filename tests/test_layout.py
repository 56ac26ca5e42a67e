"""The layout's promises (issue 11): conventions live in the core only, one edge layer for units and files."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = [p for p in ROOT.rglob("*") if p.suffix in (".py", ".rs", ".md") and "target" not in p.parts and ".git" not in p.parts]

# the factor orders of DH, MDH and ED-H links as docs/conventions.md writes them
FACTOR_ORDERS = [r"Rz\(theta ?\+ ?q\) Tz\(d\)", r"Tz\(d\) Tx\(a\) Rx\(alpha\)", r"Rx\(alpha\) Tx\(a\) Rz\(theta", r"Rx\(alpha\) Trans\(a, b, c\)",
                 r"Rx\(alpha\) Tx\(a\) Ty\(b\) Tz\(c\)", r"Rx\(alpha_\{i-1\}\) Tx\(a_\{i-1\}\)"]


def test_factor_orders_are_written_in_the_core_and_the_docs_only():
    found = {str(p.relative_to(ROOT)) for p in SOURCES for pat in FACTOR_ORDERS if re.search(pat, p.read_text(errors="ignore"))}
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
