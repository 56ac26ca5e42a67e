"""HTML reports (denavit.report): structure and numbers, static checks of the pages (in a real headless browser:
test_report_browser.py; the fixtures result, report_path, model_report_path, calibrated and every_report are in
conftest.py)."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
import pytest
from report_cases import MAX_REPORT_BYTES, REPORT_TYPES, Page, check_guo_tables, check_parameter_table

import denavit as dv
from denavit import report as rep
from denavit.errors import DenavitError

# ------------------------------------------------------------------------------------------------ static checks


def test_report_is_self_contained(report_path):
    """Offline and light: nothing to fetch, plotly.js inlined once (the gzip'ed partial bundle, inflated by the
    page's one loader), the whole page under 2 MB (it was 5 MB with the full bundle inlined)."""
    text = report_path.read_text(encoding="utf-8")
    page = Page(text)
    assert all(r.startswith(("data:", "#")) for r in page.refs), page.refs  # no src/href to fetch
    assert all("src" not in s for s in page.scripts)
    bundles = [s for s in page.scripts if s.get("id") == "plotly-bundle"]
    assert len(bundles) == 1 and bundles[0]["type"] == "application/octet-stream" and bundles[0]["code"] > 500_000
    assert sum(s["code"] > 500_000 for s in page.scripts) == 1  # plotly.js once, not once per figure
    assert "<link" not in text and "@import" not in text
    assert report_path.stat().st_size < MAX_REPORT_BYTES, report_path.stat().st_size


def test_the_inlined_bundle_is_plotly_js_with_every_trace_type_the_reports_use():
    """The vendored partial bundle is the plotly.js version the module names, and it holds the trace types of
    every figure (a type it lacks would draw nothing)."""
    import gzip
    from importlib.resources import files

    code = gzip.decompress(files("denavit.data").joinpath(rep.PLOTLY_BUNDLE).read_bytes()).decode()
    assert code.split("plotly.js (gl3d - minified) v", 1)[1].split()[0] == rep.PLOTLY_JS_VERSION
    for trace in ("scatter3d", "cone", "scatter"):
        assert f'moduleType:"trace",name:"{trace}"' in code.replace(" ", ""), trace


def test_axes_table_headers_and_the_model_configuration_have_units(report_path, tmp_path):
    """Regression: the axes table's point x/y/z headers had no unit; the model report's "configuration drawn" was
    in rad / m on a page in deg / mm."""
    page = Page(report_path.read_text(encoding="utf-8"))
    head = [c["text"] for c in page.tables["axes"][0]["cells"]]
    assert head[1:7] == ["point x [mm]", "point y [mm]", "point z [mm]", "dir x [1]", "dir y [1]", "dir z [1]"]
    text = rep.model_report_html(dv.load_robot("kr5"), q=np.radians([10, 20, 30, 40, 50, 60]))
    assert "<dt>configuration drawn</dt><dd>10, 20, 30, 40, 50, 60 (deg)</dd>" in text
    assert "<dt>configuration drawn</dt><dd>10, 20, 30, 40, 50, 60 (deg)</dd>" in rep.model_report_html(
        dv.load_robot("kr5"), q=np.radians([10, 20, 30, 40, 50, 60]), length="m"
    )


def test_summary_comes_first_and_says_what_was_measured_and_how_accurate(report_path):
    text = report_path.read_text(encoding="utf-8")
    assert text.index('id="summary"') < text.index('id="view"')
    summary = text[text.index('id="summary"') : text.index("</dl>")]
    assert (
        "72 points in 6 single-joint sweeps" in summary
        and "DH table of 6 joints" in summary
        and "accuracy" in summary
        and "with the nominal model" in summary
    )
    assert "<dt>fit chosen</dt><dd>global (one home point) over readings" in summary  # which model won, and why


def test_report_tables_hold_the_identification(report_path, result):
    page = Page(report_path.read_text(encoding="utf-8"))
    check_parameter_table(page, result)
    axes = page.rows("axes")
    assert len(axes) == 6
    for row, f in zip(axes, result.fits, strict=True):
        assert float(row["cell"]["radius"]["value"]) == pytest.approx(f.radius * 1e3, rel=1e-12)
        assert float(row["cell"]["rms"]["value"]) == pytest.approx(f.rms * 1e3, rel=1e-12)
    (box,) = page.rows("bounding-box")
    assert [float(box["cell"][k]["value"]) for k in ("l1", "l2", "l3")] == pytest.approx(
        result.box.lengths * 1e3, rel=1e-12
    )
    assert len(page.rows("pairs")) == 5


def test_model_report_tables(model_report_path):
    page = Page(model_report_path.read_text(encoding="utf-8"))
    check_guo_tables(page)
    assert len(page.rows("frames")) == 14  # 7 frames of each convention


def test_model_report_compares_with_any_convention_alias(tmp_path):
    """Regression: compare="craig" (or "MDH") was taken for a robot name ("no such robot"); convention names
    go through the core's one parser."""
    path = tmp_path / "kr5.html"
    rep.write_model_report(dv.load_robot("kr5"), path, compare="craig")
    text = path.read_text(encoding="utf-8")
    assert Page(text).rows("table-compare") and "kr5 in mdh" in text


def test_missing_plotly_names_the_install_command(result, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "plotly.graph_objects", None)
    # (the command for this installation: a checkout's folder, or 'denavit[plot]' from the package index; issue 40)
    from denavit.plotting import install_hint

    with pytest.raises(DenavitError, match=r"plotly.*" + re.escape(install_hint())):
        rep.write_report(result, tmp_path / "r.html")
    assert not list(tmp_path.iterdir())  # nothing written


def cli(*args):
    p = subprocess.run(
        [sys.executable, "-m", "denavit.cli", *args],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "120"},
    )
    assert p.returncode == 0, p.stderr
    return p


def test_cli_show_report_and_plot(tmp_path):
    cli(
        "show",
        "tiansui_mdh",
        "--compare",
        "tiansui_edh",
        "--report",
        str(tmp_path / "m.html"),
        "--plot",
        str(tmp_path / "figs"),
    )
    check_guo_tables(Page((tmp_path / "m.html").read_text(encoding="utf-8")))
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == ["frames.png", "origin_paths.png"]


def test_cli_identify_report(tmp_path):
    # the nominal kr5's own sweeps (the example before issue 40; the shipped one is now a "true" KR5's)
    sweeps = tmp_path / "kr5_nominal_30deg.csv"
    cli(
        "simulate", "kr5", "-o", str(sweeps), "--ranges", "paper30", "--points", "40", "--noise", "0.02", "--seed", "30"
    )
    cli("identify", "kr5", str(sweeps), "--convention", "dh", "--report", str(tmp_path / "r.html"))
    page = Page((tmp_path / "r.html").read_text(encoding="utf-8"))
    rows = page.rows("parameters")
    d1 = next(r for r in rows if r["attrs"] == {"data-joint": "A1", "data-param": "d"})
    assert float(d1["cell"]["identified"]["value"]) == pytest.approx(400, abs=0.5)  # Hayat Table III: 400.022 (30 deg)


def test_each_choice_of_auto_is_named_once_and_no_notes_is_not_a_warning(report_path, result):
    """The summary had shown "fit chosen" twice (the fit, then the reading scales) and "Notes: none" as an orange
    warning bullet (issue 40, item 11)."""
    text = report_path.read_text(encoding="utf-8")
    summary = text[text.index('id="summary"') : text.index("</dl>")]
    assert summary.count("<dt>fit chosen</dt>") == 1
    assert summary.count("<dt>reading scales</dt>") == sum(
        "scale error" in n for n in result.notes if n.startswith("auto: ")
    )
    import dataclasses

    quiet = dataclasses.replace(result, notes=[])
    html_text = rep.report_html(quiet)
    notes = html_text[html_text.index('id="notes-section"') :]
    assert '<p class="none" id="notes">none</p>' in notes and "<li>" not in notes[: notes.index("</section>")]


def test_the_compensation_error_figure_has_whole_position_numbers():
    """A program of a few positions had got x ticks at 1, 1.5, 2 (issue 40, item 11): ticks are whole numbers, one per
    position up to 20 positions."""
    from denavit import compensation as cp

    kr5 = dv.load_robot("kr5")
    q = np.random.default_rng(5).uniform(kr5.lower, kr5.upper, (3, 6)) * 0.5
    c = cp.compensate(kr5.model(), kr5.model(), dv.fk_batch(kr5.model(), q), q_nominal=q)
    flat = re.sub(r"\s", "", rep.compensation_report_html(c, kr5, kr5))
    axis = flat[flat.index('"xaxis":{"title":{"text":"position"}') :][:120]
    assert '"tickformat":"d"' in axis and '"dtick":1' in axis, axis


def test_the_residual_scatter_says_what_its_x_axis_is(result):
    """The identification report's residual scatter had no x tick labels (issue 40, item 11): one labelled tick per
    joint, under the middle of its points, naming the joint and its number of points; no zero line over point 0."""
    go, _ = rep.html._plotly()
    fig = rep._residual_chart(go, result, 1e-3, "mm")
    ax = fig.layout.xaxis
    assert ax.showticklabels is not False and ax.tickmode == "array" and ax.zeroline is False
    names = [result.nominal.names[s.joint - 1] for s in result.sweeps.sweeps]
    assert list(ax.ticktext) == [f"{n}: {len(f.residuals)} points" for n, f in zip(names, result.fits, strict=True)]
    joints = [t for t in fig.data if t.showlegend is not False]  # one trace of points per joint (outliers apart)
    for tick, t in zip(ax.tickvals, joints, strict=True):
        assert min(t.x) <= tick <= max(t.x)


def test_the_calibration_report_shows_no_notes_as_a_plain_none(calibrated):
    """'Notes: none' was an orange warning bullet in the calibration report too (issue 40, item 11); the misfit
    chart's zero line no longer hides pose 0."""
    import dataclasses

    res = calibrated[0]
    text = rep.calibration_report_html(dataclasses.replace(res, notes=[]))
    notes = text[text.index('id="notes-section"') :]
    notes = notes[: notes.index("</section>")]
    assert '<p class="none" id="notes">none</p>' in notes and "<li>" not in notes
    flat = re.sub(r"\s", "", text)
    axis = flat[flat.index('"xaxis":{"title":{"text":"fittedpose"}') :][:80]
    assert '"zeroline":false' in axis, axis
    if res.notes:  # notes are still listed as such
        text = rep.calibration_report_html(res)
        assert text.count("<li>", text.index('id="notes-section"')) == len(res.notes)


def test_the_compensation_positions_table_names_their_folder_once():
    """The positions of a program were listed with the program's absolute folder on every row: the folder once in
    the caption, each row its file and line."""
    from denavit import compensation as cp

    kr5 = dv.load_robot("kr5")
    q = np.random.default_rng(5).uniform(kr5.lower, kr5.upper, (3, 6)) * 0.5
    c = cp.compensate(kr5.model(), kr5.model(), dv.fk_batch(kr5.model(), q), q_nominal=q)
    where = ["/robots/cell 4/prog.dat:12", "/robots/cell 4/prog.dat:15", "/robots/cell 4/sub.dat:3"]
    text = rep.compensation_report_html(c, kr5, kr5, where=where)
    cells = [r["cell"]["position"]["text"] for r in Page(text).rows("positions")]
    assert cells == ["prog.dat:12", "prog.dat:15", "sub.dat:3"]
    caption = re.search(r'<table id="positions"[^>]*><caption>(.*?)</caption>', text).group(1)
    assert caption == "Per position; files in /robots/cell 4/."
    # no common folder: the places as given
    text = rep.compensation_report_html(c, kr5, kr5, where=["a.csv:2", "b.csv:2", "position 3"])
    assert [r["cell"]["position"]["text"] for r in Page(text).rows("positions")] == ["a.csv:2", "b.csv:2", "position 3"]


# ------------------------------------------------------------------------------------------------ every report type


@pytest.mark.parametrize("kind", REPORT_TYPES)
def test_every_report_type_is_light_and_self_contained(every_report, kind):
    text = every_report[kind].read_text(encoding="utf-8")
    page = Page(text)
    assert all(r.startswith(("data:", "#")) for r in page.refs) and all("src" not in s for s in page.scripts)
    assert sum(s.get("id") == "plotly-bundle" for s in page.scripts) == 1
    assert every_report[kind].stat().st_size < MAX_REPORT_BYTES
    assert text.index('id="summary"') < text.index(f'id="{rep.VIEW_ID}"')
