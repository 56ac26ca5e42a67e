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
    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=12,
        noise=2e-5,
        seed=7,
    )
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
            turned = np.arccos(
                np.clip(np.dot(rel[0] - (rel[0] @ z) * z, rel[-1] - (rel[-1] @ z) * z) / r[0] ** 2, -1, 1)
            )
            np.testing.assert_allclose(turned, 1.5, atol=1e-6)


def test_parameters_errorbars_are_identified_minus_nominal(result):
    """Every determined parameter is drawn at its joint with its one-sigma bar; the held ones (sigma 0) are not."""
    fig = plotting.plot_parameters(result)
    axes = by_gid(fig.axes, "param-.*")
    assert [a.get_gid() for a in axes] == ["param-d", "param-theta", "param-a", "param-alpha"]
    truth = dv.load_robot("kr5").table.params
    for k, ax in enumerate(axes):
        (eb,) = ax.containers
        scale = np.radians(1) if result.table.angle_columns[k] else MM
        drawn = np.flatnonzero(result.sigma[:, k] > 0)
        np.testing.assert_array_equal(eb.lines[0].get_xdata(), drawn + 1)
        np.testing.assert_allclose(
            eb.lines[0].get_ydata() * scale, result.table.params[drawn, k] - truth[drawn, k], atol=1e-12
        )
        segs = eb.lines[2][0].get_segments()  # vertical bars: +-sigma
        np.testing.assert_allclose([(s[1, 1] - s[0, 1]) / 2 * scale for s in segs], result.sigma[drawn, k], atol=1e-12)


def test_write_figures_writes_every_figure(result, tmp_path):
    paths = rep.write_figures(result, tmp_path / "figs", dpi=60)
    figures = ("circles", "residuals", "bounding_box", "parameters", "frames", "origin_paths") + (
        ("accuracy",) if result.nominal is not None else ()
    )
    assert sorted(p.name for p in paths) == sorted(f"{n}.png" for n in figures)
    for p in paths:
        with Image.open(p) as im:
            rgb = np.asarray(im.convert("RGB")).reshape(-1, 3).astype(np.int64)
            assert (
                im.size[0] > 300 and len(np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2])) > 50
            )  # drawn, not blank
    assert not list((tmp_path / "figs").glob(".*.tmp*"))  # no temporary file left behind


def test_model_figures(tmp_path):
    paths = rep.write_model_figures(dv.load_robot("tiansui_mdh"), tmp_path, compare="tiansui_edh", formats=("svg",))
    assert [p.name for p in paths] == ["frames.svg", "origin_paths.svg"]
    assert len(re.findall(r'<g id="frame-\d+-z"', paths[0].read_text())) == 14


def test_missing_matplotlib_names_the_install_command(result, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    # (the command for this installation: a checkout's folder, or 'denavit[plot]' from the package index; issue 40)
    with pytest.raises(DenavitError, match=r"matplotlib.*" + re.escape(plotting.install_hint())):
        plotting.plot_circles(result)


def test_core_does_not_import_the_plotting_libraries():
    code = (
        "import sys, denavit, denavit.cli, denavit.plotting, denavit.report, denavit.identification; "
        "bad = [m for m in ('matplotlib', 'plotly') if m in sys.modules]; assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_accuracy_figure_shows_the_nominal_error_and_the_prediction(result):
    """The accuracy map (issue 14): histograms of the nominal model's error and of the identified model's
    predicted error, and the nominal error over the tool positions; the numbers are the map's."""
    from denavit.accuracy import identification_accuracy

    acc = identification_accuracy(result, count=200)
    assert acc is not None and acc.nominal.shape == acc.identified.shape == (200,)
    fig = plotting.plot_accuracy(acc)
    (hist,) = by_gid(fig.axes, "accuracy-histogram")
    assert len(hist.patches) == 2 * 39 and "nominal model: rms" in hist.get_legend().get_texts()[0].get_text()
    (amap,) = by_gid(fig.axes, "accuracy-map")
    np.testing.assert_allclose(amap.collections[0].get_offsets(), acc.points[:, :2] / MM)


# ------------------------------------------------------------------------------------------------ issue 17: figures
# that explain themselves


def test_scene_view_frames_a_tall_robot_without_squashing_an_axis():
    """Regression: aspectmode "data" drew a 1.5 m tall, 0.2 m wide robot with a squashed x axis (ticks on top of
    each other, no room for the title). The view keeps one scale on all axes, no axis below half the longest,
    holds every point, and puts the camera where the box's bounding sphere fits plotly's 45 degree view."""
    rng = np.random.default_rng(0)
    pts = rng.uniform([-100, -50, 0], [100, 50, 1500], (200, 3))
    v = plotting.scene_view(pts)
    lo, hi = v["ranges"][:, 0], v["ranges"][:, 1]
    assert np.all(pts >= lo) and np.all(pts <= hi)
    assert v["aspectratio"].max() == 1 and v["aspectratio"].min() >= 0.5
    np.testing.assert_allclose((hi - lo) / v["aspectratio"], (hi - lo)[2], rtol=1e-12)  # the same scale on x, y, z
    radius = np.linalg.norm(v["aspectratio"]) / 2
    assert radius / np.linalg.norm(v["eye"]) <= np.sin(np.radians(22.5)) / 1.1  # fits, with room for the labels
    flat = plotting.scene_view(np.array([[0.0, 0, 0], [1, 1, 0]]))  # a planar cloud still gets a z extent
    assert flat["ranges"][2, 1] - flat["ranges"][2, 0] > 0.5
    with pytest.raises(DenavitError, match="at least one finite point"):
        plotting.scene_view(np.full((2, 3), np.nan))


def test_coincident_wrist_frames_get_one_label_and_nested_triads():
    """Regression: the KR5's DH frames 4, 5 and 6 share an origin: three labels overlapped and frame 6's triad hid
    frames 4 and 5. One label "4,5,6"; triads 100 %, 70 %, 49 % long."""
    t = dv.load_robot("kr5").table
    o = t.frames(np.zeros(6))[:, :3, 3]
    assert [text for _, text in plotting.frame_labels(o, 1e-6)] == ["0", "1", "2", "3", "4,5,6"]
    np.testing.assert_allclose(plotting.triad_lengths(o, 0.1), [0.1, 0.1, 0.1, 0.1, 0.1, 0.07, 0.049])
    assert plotting.clusters(np.array([[0.0, 0, 0], [0.5, 0, 0], [2, 0, 0], [0.9, 0, 0]]), 1.0) == [[0, 1, 3], [2]]
    fig = plotting.plot_frames([t])
    (ax,) = fig.axes
    assert sorted(x.get_text().strip() for x in ax.texts) == ["0", "1", "2", "3", "4,5,6"]


@pytest.mark.parametrize("convention", ["dh", "mdh", "edh"])
def test_chain_path_follows_the_link_transforms(convention):
    """Regression: the skeleton went straight from one frame origin to the next, so ED-H frames (on the axes, at
    the circle centres) zig-zagged. The chain path visits every origin in order, and each link's part has the
    length of its translations (|d| + |a|; |a| + |b| + |c|), each segment along an axis of the link's factors."""
    robot = dv.load_robot("kr5")
    t = robot.table if convention == "dh" else dv.to_table(robot.model(), convention).table
    q = np.radians([10, -20, 30, 40, 50, 60])
    F = t.frames(q)
    path = plotting.chain_path(t, q)
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    at = [int(np.argmin(np.linalg.norm(path - o, axis=1))) for o in F[:, :3, 3]]
    assert at == sorted(at) and all(np.linalg.norm(path[i] - o) < 1e-12 for i, o in zip(at, F[:, :3, 3], strict=True))
    cols = list(t.columns)
    lengths = [
        sum(abs(t.params[i, cols.index(c)]) for c in {"dh": "da", "mdh": "ad", "edh": "abc"}[convention])
        for i in range(6)
    ]
    np.testing.assert_allclose([seg[a:b].sum() for a, b in zip(at[:-1], at[1:], strict=True)], lengths, atol=1e-12)
    straight = np.linalg.norm(np.diff(F[:, :3, 3], axis=0), axis=1)
    assert seg.sum() > straight.sum() + 1e-3  # not the straight skeleton


def test_poe_chain_path_is_the_straight_skeleton():
    t = dv.to_table(dv.load_robot("kr5").model(), "poe").table
    F = t.frames(np.zeros(6))
    path = plotting.chain_path(t, np.zeros(6))
    o = F[:, :3, 3]
    keep = [o[0]] + [b for a, b in zip(o[:-1], o[1:], strict=True) if np.linalg.norm(b - a) > 1e-12]
    np.testing.assert_allclose(path, keep, atol=1e-15)


def test_clean_ticks_and_symmetric_limits():
    """Regression: a round-off difference (-3.945e-15 mm) made its own axis of +-1e-15 with unreadable ticks."""
    np.testing.assert_array_equal(plotting.clean_ticks([-3.945e-15, 0.02, -0.01]), [0.0, 0.02, -0.01])
    np.testing.assert_array_equal(plotting.clean_ticks([-3.945e-15, 2e-16]), [0.0, 0.0])
    assert plotting.clean_ticks([1e-6, -2e-6])[1] == -2e-6  # a real micro difference stays
    assert plotting.symmetric_limit([0.0, 0.0], [0.0, 0.0], 1e-6) == 1e-6
    assert plotting.symmetric_limit([0.01, -0.03], [0.005, 0.01], 1e-6) == pytest.approx(1.15 * 0.04)


def test_parameters_figure_has_no_round_off_ticks_nor_overlapping_names(result):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plotting.plot_parameters(result)
    FigureCanvasAgg(fig).draw()
    r = fig.canvas.get_renderer()
    for ax in by_gid(fig.axes, "param-.*"):
        texts = [t.get_text() for t in ax.get_yticklabels()] + [ax.yaxis.get_offset_text().get_text()]
        assert not any(re.search(r"e-1\d|\{-1\d\}", x) for x in texts), texts
        boxes = [t.get_window_extent(r) for t in ax.get_xticklabels()]
        assert all(a.x1 <= b.x0 + 0.5 for a, b in zip(boxes[:-1], boxes[1:], strict=True))  # joint names side by side


@pytest.fixture(scope="module")
def near_parallel_edh():
    """KR5 identified in ED-H from short sweeps, with the sigmas that an ED-H extraction without the nominal's x for
    the near-parallel pair 2-3 gives (a of joint 3 and theta of joints 2 and 3: a metre / a hundred degrees, issue
    17's +-870 mm error bars; with the nominal they are bounded, issue 12)."""
    from dataclasses import replace

    s = sw.simulate(
        dv.load_model("kr5"),
        home=np.radians(sw.PAPER_HOME_DEG),
        ranges=np.radians(sw.PAPER_RANGES_DEG[90]),
        points_per_sweep=12,
        noise=2e-5,
        seed=7,
    )
    res = dv.identify(s, nominal=dv.load_robot("kr5"), convention="edh")
    free = dv.identify(s, convention="edh")  # no nominal: the pair's x along its ill-defined common normal
    assert (
        free.sigma[2, 1] > 0.5 and free.sigma[1, 4] > 0.5 and free.sigma[2, 4] > 0.5 and res.sigma[2, 1] < 1e-3
    )  # m, rad: the premise
    return replace(res, sigma=free.sigma)


def test_undetermined_parameters_are_not_charted(near_parallel_edh):
    res = near_parallel_edh
    rows = {r.column: r for r in plotting.parameter_errors(res)}
    extent = plotting.scene_size(res.sweeps.all_points)
    for k, c in enumerate(res.table.columns):
        limit = plotting.UNDETERMINED_ANGLE if res.table.angle_columns[k] else plotting.UNDETERMINED_LENGTH * extent
        expected = ["held" if s == 0 else "undetermined" if s > limit else "" for s in res.sigma[:, k]]
        assert rows[c].why == expected
    assert (
        rows["a"].why[2] == rows["theta"].why[1] == rows["theta"].why[2] == "undetermined"
        and rows["alpha"].why[0] == "held"
    )
    fig = plotting.plot_parameters(res)
    for ax in by_gid(fig.axes, "param-.*"):
        (eb,) = ax.containers
        r = rows[ax.get_gid()[len("param-") :]]
        np.testing.assert_array_equal(eb.lines[0].get_xdata(), np.flatnonzero(r.shown) + 1)
        assert max(abs(np.asarray(eb.lines[0].get_ydata()))) < 1.0  # no error of hundreds of mm or deg drawn
    go = pytest.importorskip("plotly.graph_objects")
    from plotly.subplots import make_subplots

    chart, caption = rep._parameter_chart(go, make_subplots, res, "mm", "deg")
    # every bar drawn is of a determined parameter (below the chart's limit, in mm / deg): none of a metre or 100 deg
    lim = [
        (
            np.degrees(plotting.UNDETERMINED_ANGLE)
            if res.table.angle_columns[k]
            else plotting.UNDETERMINED_LENGTH * extent * 1e3
        )
        for k in range(len(res.table.columns))
    ]
    assert all(max(np.abs(tr.error_y.array)) < lim[int(tr.xaxis[1:] or 1) - 1] for tr in chart.data)
    assert "A3 a (undetermined)" in caption and "A3 theta (undetermined)" in caption
    assert all(
        ax.exponentformat == "power" for ax in (chart.layout[k] for k in chart.layout if k.startswith("yaxis"))
    )  # 2×10⁻⁴, never 200µ


def test_residuals_are_points_not_lines(result):
    """Regression: residuals (one distance per measured point) were joined into six series of spaghetti."""
    fig = plotting.plot_residuals(result)
    for ax in by_gid(fig.axes, r"residuals-\d"):
        assert ax.lines[1].get_linestyle() == "None" and ax.lines[1].get_marker() == "o"
    go = pytest.importorskip("plotly.graph_objects")
    assert all(tr.mode == "markers" for tr in rep._residual_chart(go, result, 1e-3, "mm").data)


def test_frame_panels_keep_their_axis_labels_inside_the_figure():
    """Regression: the right-hand panel's "z [mm]" was cut off at the figure's edge."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plotting.plot_frames(
        [("MD-H", dv.load_robot("tiansui_mdh").table), ("ED-H", dv.load_robot("tiansui_edh").table)]
    )
    FigureCanvasAgg(fig).draw()
    r = fig.canvas.get_renderer()
    for ax in fig.axes:
        for label in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label):
            b = label.get_window_extent(r)
            assert label.get_text() and b.x0 >= 0 and b.x1 <= fig.bbox.x1 and b.y0 >= 0 and b.y1 <= fig.bbox.y1, (
                label.get_text(),
                b,
                fig.bbox,
            )


def test_the_install_hint_is_the_command_for_the_installation_at_hand(monkeypatch):
    """PEP 610: a checkout installed with pip (editable or not) records its folder in direct_url.json; the advice
    installs the extra from that folder. From the package index there is no folder: 'denavit[plot]' (issue 40)."""
    from importlib import metadata

    class Dist:
        def __init__(self, text):
            self.text = text

        def read_text(self, name):
            assert name == "direct_url.json"
            return self.text

    for text, want in [
        (
            '{"url": "file:///home/me/denavit", "dir_info": {"editable": true}}',
            'pip install -e "/home/me/denavit[plot]"',
        ),
        ('{"url": "file:///srv/a%20b", "dir_info": {}}', 'pip install "/srv/a b[plot]"'),
        (None, "pip install 'denavit[plot]'"),
        ('{"url": "https://files.example/denavit-0.1.0.tar.gz", "archive_info": {}}', "pip install 'denavit[plot]'"),
    ]:
        monkeypatch.setattr(metadata, "distribution", lambda _name, t=text: Dist(t))
        assert plotting.install_hint() == f"install the plot extra: {want}"
