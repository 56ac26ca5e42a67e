"""HTML reports (denavit.report) in a real headless browser (their structure and numbers: test_report.py).

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
import os
import select
import shutil
import signal
import subprocess
import time

import numpy as np
import pytest
from PIL import Image
from report_cases import REPORT_TYPES, Page, check_guo_tables, check_parameter_table

from denavit import report as rep

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
            "no chromium (or chromium-browser) on PATH: install Debian's chromium (apt-get install chromium; .ci/run"
            " does) to run the browser tests"
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
        f"Array.from(document.querySelectorAll('#{rep.VIEW_ID} .legend .traces')).map(e => {{const r ="
        " e.getBoundingClientRect(); return [e.textContent, r.x, r.y, r.height];})"
    )
    name, x, y, h = next(e for e in entries if e[0].startswith("A2"))
    tab.click(x + 40, y + h / 2)
    deadline = time.monotonic() + 10
    while (
        tab.eval(
            f"document.getElementById('{rep.VIEW_ID}').data.filter(t => t.legendgroup === 'joint-2').every(t =>"
            " t.visible === 'legendonly')"
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
})()"""  # noqa: E501 (the page script, its lines whole)


def projected(tab) -> dict:
    return json.loads(tab.eval(PROJECTED % json.dumps(rep.VIEW_ID)))


def inside(box: dict, limit: float) -> bool:
    return all(-limit <= v <= limit for v in box["lo"] + box["hi"])


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
        "Array.from(document.querySelectorAll('script.figure')).map(s =>"
        " document.getElementById(s.dataset.for).dataset.rendered)"
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


# ------------------------------------------------------------------------------------------------ the residual scatter


def test_the_residual_scatter_draws_its_tick_labels_in_the_browser(tab, report_path, result):
    """The same, as drawn: the SVG of the chart holds one x tick label per joint, in sweep order."""
    tab.goto(report_path.as_uri())
    tab.wait_all_rendered()
    labels = tab.eval("Array.from(document.querySelectorAll('#residuals-chart .xtick text')).map(t => t.textContent)")
    assert labels == [f"{result.nominal.names[s.joint - 1]}: {len(s.points)} points" for s in result.sweeps.sweeps]
    assert tab.problems() == []
