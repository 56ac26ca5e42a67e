"""What the report tests share (tests/test_report*.py): the published tables the reports must show, a reader of a
page's tables, scripts and references, and the checks of the parameter tables against the published values."""

from __future__ import annotations

import math
from html.parser import HTMLParser

import pytest

from denavit import report as rep

# Hayat et al. Table III, "Specified" KR5 DH parameters (d = b and a in mm, theta and alpha in deg), with the twist
# signs and A3 offset Table III does not state taken as kr5.toml takes them (KUKA's axis senses, A3 0 = arm in line)
SPECIFIED = {
    "d": [400, 0, 0, 620, 0, 0],
    "theta": [0, 0, -90, 0, 0, 0],
    "a": [180, 600, 120, 0, 0, 0],
    "alpha": [-90, 0, -90, 90, -90, 0],
}


# Guo et al. Table I (MD-H) and Table II (ED-H), TianSui-One, lengths in mm, angles in deg
GUO_MDH = {
    "alpha": [0, 90, 0, 0, -90, 90],
    "a": [0, 0, -406, -386, 0, 0],
    "theta": [0, -90, 0, 90, 0, 0],
    "d": [0, 148.5, 0, 2, 128, 0],
}


GUO_EDH = {
    "alpha": [0, 90, 0, 0, -90, 90],
    "a": [0, 0, -406, -386, 0, 0],
    "b": [0, 0, 0, 0, -128, 128],
    "c": [0, 148.5, 0, -126, 0, 0],
    "theta": [0, -90, 0, 90, 0, 0],
}


# ------------------------------------------------------------------------------------------------ reading the HTML


class Page(HTMLParser):
    """Tables (id -> rows of cells {class, text, value}), script tags and every external reference of a page."""

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.tables: dict[str, list[list[dict]]] = {}
        self.scripts: list[dict] = []  # attrs + length of inline code
        self.refs: list[str] = []  # src / href values of tags
        self._table = self._row = self._cell = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for k in ("src", "href"):
            if a.get(k) is not None:
                self.refs.append(a[k])
        if tag == "script":
            self.scripts.append({**a, "code": 0})
        elif tag == "table" and a.get("id"):
            self._table = self.tables.setdefault(a["id"], [])
        elif tag == "tr" and self._table is not None:
            self._row = {"attrs": a, "cells": []}
            self._table.append(self._row)
        elif tag in ("td", "th") and self._row is not None:
            self._cell = {"class": (a.get("class") or "").split(), "text": "", "value": a.get("data-value"), "tag": tag}
            self._row["cells"].append(self._cell)

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self._cell = None
        elif tag == "tr":
            self._row = None
        elif tag == "table":
            self._table = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell["text"] += data
        if self.lasttag == "script" and self.scripts:
            self.scripts[-1]["code"] += len(data)

    def rows(self, tid: str) -> list[dict]:
        """Body rows of table ``tid``: {"attrs": ..., "cell": {class: cell}}."""
        out = []
        for r in self.tables[tid]:
            if r["cells"] and r["cells"][0]["tag"] == "td":
                out.append({"attrs": r["attrs"], "cell": {c["class"][0]: c for c in r["cells"]}})
        return out


def check_parameter_table(page: Page, result) -> None:
    """The identified values, sigmas, nominal values and differences of every joint and parameter."""
    rows = page.rows("parameters")
    t = result.table
    assert len(rows) == 6 * len(t.columns)
    for row in rows:
        i = ["A1", "A2", "A3", "A4", "A5", "A6"].index(row["attrs"]["data-joint"])
        k = t.columns.index(row["attrs"]["data-param"])
        scale = math.radians(1) if t.angle_columns[k] else 1e-3
        cell = row["cell"]
        for cls, value in (
            ("identified", t.params[i, k] / scale),
            ("sigma", result.sigma[i, k] / scale),
            ("nominal", SPECIFIED[t.columns[k]][i]),
        ):
            assert cell[cls]["text"] == rep.fmt_value(value), (cls, row["attrs"])
            assert float(cell[cls]["value"]) == pytest.approx(value, abs=1e-9), (cls, row["attrs"])
        assert float(cell["difference"]["value"]) == pytest.approx(
            t.params[i, k] / scale - SPECIFIED[t.columns[k]][i], abs=1e-9
        )
        assert float(cell["difference"]["value"]) == pytest.approx(
            0, abs=6 * result.sigma[i, k] / scale + 1e-9
        )  # within noise of Table III


def check_guo_tables(page: Page) -> None:
    for tid, golden in (("table-main", GUO_MDH), ("table-compare", GUO_EDH)):
        rows = page.rows(tid)
        assert [r["attrs"]["data-joint"] for r in rows] == [f"j{i}" for i in range(1, 7)]
        for col, values in golden.items():
            assert [float(r["cell"][col]["value"]) for r in rows] == pytest.approx(values, abs=1e-9), (tid, col)
            assert [r["cell"][col]["text"] for r in rows] == [rep.fmt_value(v) for v in values]


MAX_REPORT_BYTES = 2_000_000  # issue 17: a report of a 6-joint identification under 2 MB
REPORT_TYPES = ["identify-dh", "identify-mdh", "identify-edh", "identify-poe", "show", "calibrate", "compensate"]
