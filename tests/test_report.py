"""HTML reports (denavit.report): structure and numbers, then the page in a real headless browser.

The browser tests drive Debian's chromium through the Chrome DevTools protocol over ``--remote-debugging-pipe``
(file descriptors 3 and 4, NUL-separated JSON; no extra package). For each page they check:

* loading: no ``console.error``/``console.assert`` call, no uncaught exception (``Runtime.exceptionThrown``), no
  error-level browser log entry (``Log.entryAdded``), and no request other than the file itself (``Network``
  events; name resolution is also disabled with ``--host-resolver-rules``, so the page must work offline). A
  control page with one ``console.error`` and one uncaught exception shows that these checks do catch errors;
* the 3-D view: plotly resolves ``newPlot`` (the page's ``data-rendered`` flag), the WebGL canvas exists, and a
  screenshot of the scene is not blank: many distinct colours, and pixels of the joints' own colours (orange,
  purple, brown: colours no frame or grid uses). A real mouse click on a joint's legend entry hides all of that
  joint's traces and its colour leaves the screenshot (the legend toggles joints);
* the tables: the DOM after rendering (``document.documentElement.outerHTML``, what ``--dump-dom`` prints) holds
  the identified values, sigmas and nominal values, as text (formatted as the report formats them) and as
  full-precision ``data-value``; the nominal column is Hayat et al. Table III's "specified" KR5 values, the model
  report's tables Guo et al.'s Tables I and II.

Without chromium (or chromium-browser) on PATH the browser tests are skipped with that reason; ``.ci/run``
installs it.
"""

from __future__ import annotations

import base64
import fcntl
import io
import json
import math
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import time
from html.parser import HTMLParser

import numpy as np
import pytest
from PIL import Image

import denavit as dv
from denavit import report as rep
from denavit import sweeps as sw
from denavit.errors import DenavitError

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


@pytest.fixture(scope="module")
def report_path(result, tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "identification.html"
    rep.write_report(result, path)
    return path


@pytest.fixture(scope="module")
def model_report_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "tiansui.html"
    rep.write_model_report(dv.load_robot("tiansui_mdh"), path, compare="tiansui_edh")
    return path


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


# ------------------------------------------------------------------------------------------------ static checks


MAX_REPORT_BYTES = 2_000_000  # issue 17: a report of a 6-joint identification under 2 MB


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
    cli("identify", "--example", "kr5-30", "--report", str(tmp_path / "r.html"))
    page = Page((tmp_path / "r.html").read_text(encoding="utf-8"))
    rows = page.rows("parameters")
    d1 = next(r for r in rows if r["attrs"] == {"data-joint": "A1", "data-param": "d"})
    assert float(d1["cell"]["identified"]["value"]) == pytest.approx(400, abs=0.5)  # Hayat Table III: 400.022 (30 deg)


# ------------------------------------------------------------------------------------------------ the browser

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--mute-audio",
    "--enable-unsafe-swiftshader",  # WebGL on the software rasteriser (no GPU here), without the deprecation error
    "--host-resolver-rules=MAP * ~NOTFOUND",  # offline: no host name resolves
]
TIMEOUT = 90.0


def find_chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip(
            "no chromium (or chromium-browser) on PATH: install Debian's chromium (apt-get install chromium; .ci/run does) to run the browser tests"
        )
    return exe


class Browser:
    """A headless chromium driven over the DevTools pipe (fd 3: commands in, fd 4: replies and events out)."""

    def __init__(self, exe: str, user_dir) -> None:
        def high(fd: int) -> int:  # above 9, so that the redirections to 3 and 4 never clobber them
            h = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
            os.close(fd)
            return h

        r_in, w_in = (high(fd) for fd in os.pipe())
        r_out, w_out = (high(fd) for fd in os.pipe())
        self.log = open(user_dir / "chromium.log", "wb")  # noqa: SIM115
        cmd = [
            "bash",
            "-c",
            f'exec "$0" "$@" 3<&{r_in} 4>&{w_out} {r_in}<&- {w_out}>&-',
            exe,
            *FLAGS,
            "--remote-debugging-pipe",
            f"--user-data-dir={user_dir}",
            "about:blank",
        ]
        self.proc = subprocess.Popen(
            cmd,
            pass_fds=(r_in, w_out),
            stdin=subprocess.DEVNULL,
            stdout=self.log,
            stderr=self.log,
            start_new_session=True,
        )
        os.close(r_in)
        os.close(w_out)
        self.w, self.r = w_in, r_out
        self.buf = b""
        self.last_id = 0
        self.events: list[dict] = []

    def _message(self, deadline: float) -> dict:
        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("chromium sent nothing in time")
            if select.select([self.r], [], [], left)[0]:
                chunk = os.read(self.r, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"chromium closed the DevTools pipe; its log:\n{self.log_tail()}")
                self.buf += chunk
        msg, self.buf = self.buf.split(b"\0", 1)
        return json.loads(msg)

    def call(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        self.last_id += 1
        msg = {
            "id": self.last_id,
            "method": method,
            "params": params or {},
            **({"sessionId": session} if session else {}),
        }
        os.write(self.w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + TIMEOUT
        while True:
            m = self._message(deadline)
            if m.get("id") == self.last_id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m["result"]
            if "method" in m:
                self.events.append(m)

    def log_tail(self) -> str:
        self.log.flush()
        return open(self.log.name, "rb").read()[-3000:].decode(errors="replace")  # noqa: SIM115

    def close(self) -> None:
        try:
            self.call("Browser.close")
            self.proc.wait(15)
        except Exception:  # noqa: BLE001  -- never leave our browser behind
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
        os.close(self.w)
        os.close(self.r)
        self.log.close()


class Tab:
    """One page of the browser: navigate, evaluate, click, screenshot, and what went wrong while loading."""

    def __init__(self, browser: Browser, width: int = 1300, height: int = 1000) -> None:
        self.b = browser
        self.target = browser.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.s = browser.call("Target.attachToTarget", {"targetId": self.target, "flatten": True})["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            browser.call(f"{domain}.enable", session=self.s)
        browser.call(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
            session=self.s,
        )

    def goto(self, url: str) -> None:
        """Open ``url`` and wait until it has loaded (events of earlier pages are forgotten)."""
        self.b.call("Page.navigate", {"url": url}, session=self.s)
        deadline = time.monotonic() + TIMEOUT
        while self.eval("location.href + ' ' + document.readyState") != f"{url} complete":
            assert time.monotonic() < deadline, f"{url} did not load"
            time.sleep(0.05)

    def eval(self, expression: str):
        r = self.b.call(
            "Runtime.evaluate", {"expression": expression, "returnByValue": True, "awaitPromise": True}, session=self.s
        )
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def wait_rendered(self, element_id: str) -> None:
        deadline = time.monotonic() + TIMEOUT
        while self.eval(f"document.getElementById('{element_id}')?.dataset.rendered") != "true":
            assert time.monotonic() < deadline, f"plotly did not render #{element_id}; problems: {self.problems()}"
            time.sleep(0.1)
        self.eval("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")  # the frame is drawn

    def rect(self, selector: str) -> dict:
        """The element's box in the viewport, after scrolling it into view (a screenshot clips the viewport)."""
        el = f"document.querySelector({json.dumps(selector)})"
        self.eval(f"{el}.scrollIntoView({{block: 'center'}})")
        return json.loads(self.eval(f"JSON.stringify({el}.getBoundingClientRect())"))

    def wait_all_rendered(self) -> None:
        """Until the page's loader has drawn every figure (body data-rendered), then one frame more."""
        deadline = time.monotonic() + TIMEOUT
        while self.eval("document.body.dataset.rendered") != "true":
            assert time.monotonic() < deadline, f"the figures were not all drawn; problems: {self.problems()}"
            time.sleep(0.1)
        self.eval("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")

    def click(self, x: float, y: float) -> None:
        for kind in ("mouseMoved", "mousePressed", "mouseReleased"):
            self.b.call(
                "Input.dispatchMouseEvent",
                {"type": kind, "x": x, "y": y, "button": "left", "clickCount": 1},
                session=self.s,
            )

    def screenshot(self, rect: dict) -> Image.Image:
        """The pixels of ``rect`` (a :meth:`rect`, in viewport coordinates); the clip of Page.captureScreenshot is in
        page coordinates, so the scroll offset is added (without it a page taller than before shot its header)."""
        sx, sy = json.loads(self.eval("JSON.stringify([window.scrollX, window.scrollY])"))
        clip = {"x": rect["x"] + sx, "y": rect["y"] + sy, "width": rect["width"], "height": rect["height"], "scale": 1}
        data = self.b.call("Page.captureScreenshot", {"format": "png", "clip": clip}, session=self.s)["data"]
        return Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB")

    def close(self) -> None:
        self.b.call("Target.closeTarget", {"targetId": self.target})

    def events(self) -> list[dict]:
        """The events of this tab (its own DevTools session)."""
        return [e for e in self.b.events if e.get("sessionId") == self.s]

    def problems(self) -> list[str]:
        out = []
        for e in self.events():
            m, p = e["method"], e.get("params", {})
            if m == "Runtime.consoleAPICalled" and p["type"] in ("error", "assert"):
                out.append(
                    f"console.{p['type']}: "
                    + " ".join(str(a.get("value", a.get("description", ""))) for a in p["args"])
                )
            elif m == "Runtime.exceptionThrown":
                d = p["exceptionDetails"]
                out.append("uncaught: " + d.get("exception", {}).get("description", d.get("text", "")))
            elif m == "Log.entryAdded" and p["entry"]["level"] == "error":
                out.append(f"log: {p['entry']['text']} {p['entry'].get('url', '')}")
        return out

    def requests(self) -> list[str]:
        return [e["params"]["request"]["url"] for e in self.events() if e["method"] == "Network.requestWillBeSent"]


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    exe = find_chromium()
    b = Browser(exe, tmp_path_factory.mktemp("chromium"))
    try:
        yield b
    finally:
        b.close()


@pytest.fixture
def tab(browser):
    """A fresh tab per test: its events (errors, requests) are its own."""
    t = Tab(browser)
    try:
        yield t
    finally:
        t.close()


def colour_pixels(img: Image.Image, hex_colour: str, tol: int = 40) -> int:
    rgb = np.asarray(img, dtype=int)
    c = np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)])
    return int(np.sum(np.abs(rgb - c).max(axis=2) <= tol))


def distinct_colours(img: Image.Image) -> int:
    rgb = np.asarray(img, dtype=np.int64).reshape(-1, 3)
    return len(np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2]))


def test_browser_checks_catch_errors(tab, tmp_path):
    """Control: a page that logs an error and throws is caught by the same checks (they are not vacuous)."""
    bad = tmp_path / "bad.html"
    bad.write_text("<html><body><script>console.error('planted error'); undefinedFunction();</script></body></html>")
    tab.goto(bad.as_uri())
    problems = tab.problems()
    assert any("planted error" in p for p in problems) and any("undefinedFunction" in p for p in problems), problems


ORANGE, PURPLE, BROWN = "#ff7f0e", "#9467bd", "#8c564b"  # joints 2, 5, 6: no frame, grid or background uses them


def test_identification_report_in_browser(tab, report_path, result):
    tab.goto(report_path.as_uri())
    tab.wait_rendered(rep.VIEW_ID)
    assert tab.problems() == []
    assert [u for u in tab.requests() if not u.startswith(("file:", "data:", "blob:"))] == []
    assert tab.eval(f"document.querySelectorAll('#{rep.VIEW_ID} canvas').length") >= 1  # WebGL scene created
    # legend groups: every trace of a joint shares its group, so one click toggles the joint
    traces = tab.eval(f"document.getElementById('{rep.VIEW_ID}').data.map(t => [t.type, t.legendgroup || ''])")
    groups = {g for _, g in traces}
    assert {f"joint-{j}" for j in range(1, 7)} <= groups and {"frames-identified dh", "frames-identified edh"} <= groups
    assert sum(g == "joint-2" for _, g in traces) >= 4  # points, circle, centre, axis (+ cone)
    scene = tab.rect(f"#{rep.VIEW_ID} canvas")
    before = tab.screenshot(scene)
    assert before.size[0] > 400 and distinct_colours(before) > 200, "the 3-D view looks blank"
    counts = {c: colour_pixels(before, c) for c in (ORANGE, PURPLE, BROWN)}
    assert all(n > 30 for n in counts.values()), counts  # the joints' points, circles and axes are drawn
    # the tables as rendered (the DOM, as --dump-dom prints it)
    check_parameter_table(Page(tab.eval("document.documentElement.outerHTML")), result)
    # a real click on joint 2's legend entry hides joint 2 (its orange leaves the picture), not joint 5
    entries = tab.eval(
        f"Array.from(document.querySelectorAll('#{rep.VIEW_ID} .legend .traces')).map(e => {{const r = e.getBoundingClientRect(); return [e.textContent, r.x, r.y, r.height];}})"
    )
    name, x, y, h = next(e for e in entries if e[0].startswith("A2"))
    tab.click(x + 40, y + h / 2)
    deadline = time.monotonic() + 10
    while (
        tab.eval(
            f"document.getElementById('{rep.VIEW_ID}').data.filter(t => t.legendgroup === 'joint-2').every(t => t.visible === 'legendonly')"
        )
        is not True
    ):
        assert time.monotonic() < deadline, "the legend click did not hide joint 2"
        time.sleep(0.1)
    tab.eval("new Promise(r => setTimeout(() => requestAnimationFrame(() => requestAnimationFrame(r)), 200))")
    after = tab.screenshot(scene)
    assert colour_pixels(after, ORANGE) < 0.1 * counts[ORANGE] and colour_pixels(after, PURPLE) > 0.5 * counts[PURPLE]
    assert tab.problems() == []


def test_model_report_in_browser(tab, model_report_path):
    tab.goto(model_report_path.as_uri())
    tab.wait_rendered(rep.VIEW_ID)
    assert tab.problems() == []
    assert [u for u in tab.requests() if not u.startswith(("file:", "data:", "blob:"))] == []
    shot = tab.screenshot(tab.rect(f"#{rep.VIEW_ID} canvas"))
    assert distinct_colours(shot) > 200 and colour_pixels(shot, ORANGE) > 30  # axis of joint 2 drawn
    groups = set(tab.eval(f"document.getElementById('{rep.VIEW_ID}').data.map(t => t.legendgroup)"))
    assert {"frames-tiansui_mdh (mdh)", "frames-tiansui_edh (edh)"} <= groups and {
        f"joint-{j}" for j in range(1, 7)
    } <= groups
    check_guo_tables(Page(tab.eval("document.documentElement.outerHTML")))


# ------------------------------------------------------------------------------------------------ every report type

# Every point of every visible trace of the 3-D view, and the corners of its axis box, through plotly's own camera:
# plotly scales the data per axis (scene.dataScale), then gl-plot3d's model, view and projection matrices (column
# major) give clip coordinates; x/w and y/w in [-1, 1] are inside the canvas.
PROJECTED = """(() => {
  const gd = document.getElementById(%s), sc = gd._fullLayout.scene._scene, cp = sc.glplot.cameraParams, k = sc.dataScale;
  const mul = (m, v) => [0, 1, 2, 3].map(r => m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2] + m[12 + r] * v[3]);
  const box = (P) => {
    const lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
    for (const p of P) {
      const c = mul(cp.projection, mul(cp.view, mul(cp.model, [p[0] * k[0], p[1] * k[1], p[2] * k[2], 1])));
      for (const a of [0, 1]) { lo[a] = Math.min(lo[a], c[a] / c[3]); hi[a] = Math.max(hi[a], c[a] / c[3]); }
    }
    return {lo, hi, n: P.length};
  };
  const pts = [];
  for (const t of gd._fullData) {
    if (t.visible !== true || !t.x) continue;
    for (let i = 0; i < t.x.length; i++) if (t.x[i] !== null && t.x[i] !== undefined) pts.push([t.x[i], t.y[i], t.z[i]]);
  }
  const L = gd._fullLayout.scene, corners = [];
  for (const a of L.xaxis.range) for (const b of L.yaxis.range) for (const c of L.zaxis.range) corners.push([a, b, c]);
  return JSON.stringify({traces: box(pts), corners: box(corners)});
})()"""


def projected(tab) -> dict:
    return json.loads(tab.eval(PROJECTED % json.dumps(rep.VIEW_ID)))


def inside(box: dict, limit: float) -> bool:
    return all(-limit <= v <= limit for v in box["lo"] + box["hi"])


@pytest.fixture(scope="module")
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


@pytest.fixture(scope="module")
def every_report(result, calibrated, tmp_path_factory):
    """One report of each type: identify in each convention, show, calibrate, compensate (KR5, 6 joints)."""
    from denavit import compensation as cp

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


REPORT_TYPES = ["identify-dh", "identify-mdh", "identify-edh", "identify-poe", "show", "calibrate", "compensate"]


@pytest.mark.parametrize("kind", REPORT_TYPES)
def test_every_report_type_is_light_and_self_contained(every_report, kind):
    text = every_report[kind].read_text(encoding="utf-8")
    page = Page(text)
    assert all(r.startswith(("data:", "#")) for r in page.refs) and all("src" not in s for s in page.scripts)
    assert sum(s.get("id") == "plotly-bundle" for s in page.scripts) == 1
    assert every_report[kind].stat().st_size < MAX_REPORT_BYTES
    assert text.index('id="summary"') < text.index(f'id="{rep.VIEW_ID}"')


@pytest.mark.parametrize("kind", REPORT_TYPES)
def test_every_report_type_in_browser(tab, every_report, kind):
    """Issue 17: each report loads offline with no console error, draws every figure, its 3-D view is not blank,
    and the robot and the axis box lie inside the canvas (projected through plotly's camera): nothing is clipped
    at the top left, the axis titles have room."""
    tab.goto(every_report[kind].as_uri())
    tab.wait_all_rendered()
    assert tab.problems() == []
    assert [u for u in tab.requests() if not u.startswith(("file:", "data:", "blob:"))] == []
    figures = tab.eval(
        "Array.from(document.querySelectorAll('script.figure')).map(s => document.getElementById(s.dataset.for).dataset.rendered)"
    )
    assert figures and all(f == "true" for f in figures), figures
    shot = tab.screenshot(tab.rect(f"#{rep.VIEW_ID} canvas"))
    assert shot.size[0] > 400 and distinct_colours(shot) > 200, "the 3-D view looks blank"
    p = projected(tab)
    assert p["traces"]["n"] > 20
    assert inside(p["traces"], 0.9) and inside(p["corners"], 0.98), (
        p
    )  # the robot and the whole axis box within the canvas
    assert max(h - lo for lo, h in zip(p["traces"]["lo"], p["traces"]["hi"], strict=True)) > 0.5, (
        p
    )  # and not a speck in its middle


def test_viewport_check_catches_a_camera_too_close(tab, every_report):
    """Control: the same check fails once the camera is moved close (the robot leaves the canvas)."""
    tab.goto(every_report["identify-dh"].as_uri())
    tab.wait_all_rendered()
    assert inside(projected(tab)["traces"], 0.9)
    tab.eval(f"Plotly.relayout('{rep.VIEW_ID}', {{'scene.camera.eye': {{x: 0.5, y: -0.4, z: 0.3}}}}).then(() => true)")
    tab.eval("new Promise(r => setTimeout(() => requestAnimationFrame(() => requestAnimationFrame(r)), 300))")
    assert not inside(projected(tab)["traces"], 0.9)


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


def test_the_compensation_error_figure_has_whole_target_numbers():
    """A program of a few targets had got x ticks at 1, 1.5, 2 (issue 40, item 11): ticks are whole numbers, one per
    target up to 20 targets."""
    from denavit import compensation as cp

    kr5 = dv.load_robot("kr5")
    q = np.random.default_rng(5).uniform(kr5.lower, kr5.upper, (3, 6)) * 0.5
    c = cp.compensate(kr5.model(), kr5.model(), dv.fk_batch(kr5.model(), q), q_nominal=q)
    flat = re.sub(r"\s", "", rep.compensation_report_html(c, kr5, kr5))
    axis = flat[flat.index('"xaxis":{"title":{"text":"target"}') :][:120]
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


def test_the_residual_scatter_draws_its_tick_labels_in_the_browser(tab, report_path, result):
    """The same, as drawn: the SVG of the chart holds one x tick label per joint, in sweep order."""
    tab.goto(report_path.as_uri())
    tab.wait_all_rendered()
    labels = tab.eval("Array.from(document.querySelectorAll('#residuals-chart .xtick text')).map(t => t.textContent)")
    assert labels == [f"{result.nominal.names[s.joint - 1]}: {len(s.points)} points" for s in result.sweeps.sweeps]
    assert tab.problems() == []


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


def test_the_compensation_targets_table_names_their_folder_once():
    """The targets of a program were listed with the program's absolute folder on every row: the folder once in
    the caption, each row its file and line."""
    from denavit import compensation as cp

    kr5 = dv.load_robot("kr5")
    q = np.random.default_rng(5).uniform(kr5.lower, kr5.upper, (3, 6)) * 0.5
    c = cp.compensate(kr5.model(), kr5.model(), dv.fk_batch(kr5.model(), q), q_nominal=q)
    where = ["/robots/cell 4/prog.dat:12", "/robots/cell 4/prog.dat:15", "/robots/cell 4/sub.dat:3"]
    text = rep.compensation_report_html(c, kr5, kr5, where=where)
    cells = [r["cell"]["target"]["text"] for r in Page(text).rows("targets")]
    assert cells == ["prog.dat:12", "prog.dat:15", "sub.dat:3"]
    caption = re.search(r'<table id="targets"[^>]*><caption>(.*?)</caption>', text).group(1)
    assert caption == "Per target; files in /robots/cell 4/."
    # no common folder: the places as given
    text = rep.compensation_report_html(c, kr5, kr5, where=["a.csv:2", "b.csv:2", "target 3"])
    assert [r["cell"]["target"]["text"] for r in Page(text).rows("targets")] == ["a.csv:2", "b.csv:2", "target 3"]
