"""Static figures (denavit.plotting): each figure is built headless and its artists are counted and measured.

The figures are checked from the Figure objects (the artists' gids and data), not from the files alone: one
fitted circle per joint lying on the fitted circle, one axis arrow per joint, 12 box edges with the box's
lengths, a triad per frame at Table.frames' origins, origin paths that are circles about the moving axis.
"""

import re
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import denavit as dv
from denavit import plotting
from denavit import report as rep
from denavit import sweeps as sw
from denavit.errors import DenavitError

MM = 1e-3


@pytest.fixture(scope="module")
def result():
    """A small simulated identification: KR5, Hayat's home and 90 degree ranges, 12 points per sweep, 20 um noise."""
    s = sw.simulate(dv.load_model("kr5"), home=np.radians(sw.PAPER_HOME_DEG), ranges=np.radians(sw.PAPER_RANGES_DEG[90]), points_per_sweep=12, noise=2e-5, seed=7)
    return dv.identify(s, nominal=dv.load_robot("kr5"))


def by_gid(artists, pattern):
    return [a for a in artists if a.get_gid() and re.fullmatch(pattern, a.get_gid())]


def test_circles_one_circle_centre_and_axis_per_joint(result):
    fig = plotting.plot_circles(result)
    (ax,) = fig.axes
    circles = by_gid(ax.lines, r"circle-\d")
    assert len(circles) == result.axes.nq == 6
    assert len(by_gid(ax.collections, r"axis-\d")) == 6  # one quiver arrow per joint
    assert len(by_gid(ax.collections, r"centre-\d")) == 6
    points = by_gid(ax.collections, r"points-\d")
    assert [len(p.get_offsets()) for p in points] == [12] * 6
    for line in circles:  # the drawn curve is the full fitted circle (mm): constant radius, in the plane, closed
        f = result.fits[int(line.get_gid().split("-")[1]) - 1]
        xyz = np.array(line.get_data_3d()).T * MM
        rel = xyz - f.point
        np.testing.assert_allclose(rel @ f.direction, 0, atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(rel, axis=1), f.radius, rtol=1e-9)
        np.testing.assert_allclose(xyz[0], xyz[-1], atol=1e-9)


def test_circles_svg_holds_one_group_per_circle(result, tmp_path):
    fig = plotting.plot_circles(result)
    fig.savefig(tmp_path / "c.svg")
    svg = (tmp_path / "c.svg").read_text()
    assert len(re.findall(r'<g id="circle-\d"', svg)) == 6
    assert len(re.findall(r'<g id="axis-\d"', svg)) == 6


def test_residuals_one_axes_per_joint_with_the_fit_residuals(result):
    fig = plotting.plot_residuals(result)
    axes = by_gid(fig.axes, r"residuals-\d")
    assert len(axes) == 6
    for ax, f in zip(axes, result.fits, strict=True):
        np.testing.assert_allclose(ax.lines[1].get_ydata() * MM, f.residuals, rtol=1e-12)  # lines[0] is the zero line


def test_bounding_box_has_twelve_edges_of_the_box_lengths(result):
    fig = plotting.plot_bounding_box(result)
    (ax,) = fig.axes
    edges = by_gid(ax.lines, "box-edge")
    assert len(edges) == 12
    lengths = sorted(float(np.linalg.norm(np.diff(np.array(e.get_data_3d()).T, axis=0))) * MM for e in edges)
    np.testing.assert_allclose(lengths, np.repeat(np.sort(result.box.lengths), 4), rtol=1e-9)
    assert len(by_gid(ax.collections, r"box-axis-\d")) == 3
    assert all(len(p.get_offsets()) == 12 for p in by_gid(ax.collections, r"points-\d"))


def origins_drawn(ax):
    """Frame origins (m) from the drawn triads: the first point of each frame-i-x line."""
    lines = sorted(by_gid(ax.lines, r"frame-\d+-x"), key=lambda a: int(a.get_gid().split("-")[1]))
    return np.array([np.array(a.get_data_3d())[:, 0] for a in lines]) * MM


def distinct(points, tol=1e-9):
    out = []
    for p in points:
        if all(np.linalg.norm(p - o) > tol for o in out):
            out.append(p)
    return len(out)


def test_frames_side_by_side_tiansui_mdh_overlaps_edh_does_not():
    """Guo et al. Tables I/II (TianSui-One at q = 0): the MD-H frames 5 and 6 share an origin (and 0, 1 do in both),
    the ED-H frames sit apart on the axes: 5 distinct origins of 7 in MD-H, 6 in ED-H (sec. IV.A, Fig. 7)."""
    mdh, edh = dv.load_robot("tiansui_mdh").table, dv.load_robot("tiansui_edh").table
    fig = plotting.plot_frames([("MD-H", mdh), ("ED-H", edh)])
    a_mdh, a_edh = by_gid(fig.axes, "frames-.*")
    for ax, table in ((a_mdh, mdh), (a_edh, edh)):
        for k in "xyz":
            assert len(by_gid(ax.lines, rf"frame-\d+-{k}")) == 7
        assert len(by_gid(ax.lines, "skeleton")) == 1
        np.testing.assert_allclose(origins_drawn(ax), table.frames(np.zeros(6))[:, :3, 3], atol=1e-12)
    assert distinct(origins_drawn(a_mdh)) == 5 and distinct(origins_drawn(a_edh)) == 6
    assert a_mdh.get_xlim() == a_edh.get_xlim() and a_mdh.get_zlim() == a_edh.get_zlim()  # comparable side by side


def test_frames_of_a_robot_and_its_to_table_conversion():
    robot = dv.load_robot("kr5")
    other = dv.to_table(robot.model(), "edh").table
    q = np.radians(sw.PAPER_HOME_DEG)
    fig = plotting.plot_frames([robot.table, other], q)
    assert len(fig.axes) == 2
    for ax, t in zip(fig.axes, (robot.table, other), strict=True):
        np.testing.assert_allclose(origins_drawn(ax), t.frames(q)[:, :3, 3], atol=1e-12)


def test_origin_paths_are_circles_about_the_moving_axis():
    """Joint 2 of the KR5 moves: every frame origin beyond it turns on a circle about axis 2; in ED-H the frame of
    joint 2 stays put (it is on its axis), in standard DH frame 2 sits at the end of link 2 and travels."""
    robot = dv.load_robot("kr5")
    m = robot.model()
    edh = dv.to_table(m, "edh").table
    fig = plotting.plot_origin_paths([("dh", robot.table), ("edh", edh)], 2, limits=(-1.0, 0.5))
    axis = dv.joint_frames(m, np.zeros(6))[1]
    p0, z = axis[:3, 3], axis[:3, 2]
    for ax, label in zip(fig.axes, ("dh", "edh"), strict=True):
        paths = {int(a.get_gid().split("-")[1]): np.array(a.get_data_3d()).T * MM for a in by_gid(ax.lines, r"path-\d")}
        assert sorted(paths) == list(range(7))
        moving = [i for i, p in paths.items() if len(p) > 1]
        assert moving == ([2, 3, 4, 5, 6] if label == "dh" else [3, 4, 5, 6])
        for i in moving:
            rel = paths[i] - p0
            r = np.linalg.norm(rel - np.outer(rel @ z, z), axis=1)
            np.testing.assert_allclose(r, r[0], atol=1e-9)
            np.testing.assert_allclose(rel @ z, (rel @ z)[0], atol=1e-9)
            turned = np.arccos(np.clip(np.dot(rel[0] - (rel[0] @ z) * z, rel[-1] - (rel[-1] @ z) * z) / r[0] ** 2, -1, 1))
            np.testing.assert_allclose(turned, 1.5, atol=1e-6)


def test_parameters_errorbars_are_identified_minus_nominal(result):
    fig = plotting.plot_parameters(result)
    axes = by_gid(fig.axes, "param-.*")
    assert [a.get_gid() for a in axes] == ["param-d", "param-theta", "param-a", "param-alpha"]
    truth = dv.load_robot("kr5").table.params
    for k, ax in enumerate(axes):
        (eb,) = ax.containers
        scale = np.radians(1) if result.table.angle_columns[k] else MM
        np.testing.assert_allclose(eb.lines[0].get_ydata() * scale, result.table.params[:, k] - truth[:, k], atol=1e-12)
        segs = eb.lines[2][0].get_segments()  # vertical bars: +-sigma
        np.testing.assert_allclose([(s[1, 1] - s[0, 1]) / 2 * scale for s in segs], result.sigma[:, k], atol=1e-12)


def test_write_figures_writes_every_figure(result, tmp_path):
    paths = rep.write_figures(result, tmp_path / "figs", dpi=60)
    figures = ("circles", "residuals", "bounding_box", "parameters", "frames", "origin_paths") + (("accuracy",) if result.nominal is not None else ())
    assert sorted(p.name for p in paths) == sorted(f"{n}.png" for n in figures)
    for p in paths:
        with Image.open(p) as im:
            rgb = np.asarray(im.convert("RGB")).reshape(-1, 3).astype(np.int64)
            assert im.size[0] > 300 and len(np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2])) > 50  # drawn, not blank
    assert not list((tmp_path / "figs").glob(".*.tmp*"))  # no temporary file left behind


def test_model_figures(tmp_path):
    paths = rep.write_model_figures(dv.load_robot("tiansui_mdh"), tmp_path, compare="tiansui_edh", formats=("svg",))
    assert [p.name for p in paths] == ["frames.svg", "origin_paths.svg"]
    assert len(re.findall(r'<g id="frame-\d+-z"', paths[0].read_text())) == 14


def test_missing_matplotlib_names_the_install_command(result, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(DenavitError, match=r"matplotlib.*pip install 'denavit\[plot\]'"):
        plotting.plot_circles(result)


def test_core_does_not_import_the_plotting_libraries():
    code = ("import sys, denavit, denavit.cli, denavit.plotting, denavit.report, denavit.identify; "
            "bad = [m for m in ('matplotlib', 'plotly') if m in sys.modules]; assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_accuracy_figure_shows_the_nominal_error_and_the_prediction(result):
    """The accuracy map (issue 14): histograms of the nominal model's error and of the identified model's
    predicted error, and the nominal error over the tool positions; the numbers are the map's."""
    from denavit.compensation import identification_accuracy

    acc = identification_accuracy(result, count=200)
    assert acc is not None and acc.nominal.shape == acc.identified.shape == (200,)
    fig = plotting.plot_accuracy(acc)
    hist, = by_gid(fig.axes, "accuracy-histogram")
    assert len(hist.patches) == 2 * 39 and "nominal model: rms" in hist.get_legend().get_texts()[0].get_text()
    amap, = by_gid(fig.axes, "accuracy-map")
    np.testing.assert_allclose(amap.collections[0].get_offsets(), acc.points[:, :2] / MM)
