"""The build report in a real browser: headless Chromium opens report.html from disk with every host name
unresolvable, draws the Gantt with one bar per activity (counted in the DOM and in the plot's data),
shows a bar's component on hover, and its screenshot is not blank: the three task colours are there."""

from __future__ import annotations

import base64
import csv
import io
import json
import shutil
import time

import numpy as np
import pytest

pytestmark = pytest.mark.browser

WINDOW = (1280, 900)
#: The Gantt's bar colours by task (bimrobot.report.charts.TASK_COLOURS) as RGB.
TASK_RGB = {"transport": (0x4C, 0x72, 0xB0), "position": (0xDD, 0x84, 0x52), "assemble": (0x55, 0xA8, 0x68)}


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


@pytest.fixture
def browser():
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed (pip install selenium)")
    from selenium.webdriver.chrome.service import Service

    binary, driver = _chromium(), shutil.which("chromedriver")
    if binary is None or driver is None:
        pytest.skip("Debian's chromium and chromium-driver are not installed (scripts/setup.sh installs them)")
    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for argument in ("--headless=new", "--no-sandbox", f"--window-size={WINDOW[0]},{WINDOW[1]}",
                     "--force-device-scale-factor=1",
                     # no network: every host name fails to resolve, so a CDN script could not load
                     "--host-resolver-rules=MAP * ~NOTFOUND"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"performance": "ALL"})
    session = webdriver.Chrome(service=Service(driver), options=options)
    try:
        yield session
    finally:
        session.quit()


def _requests(browser) -> list[str]:
    """The URL of every request the page began."""
    urls = []
    for entry in browser.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message["method"] == "Network.requestWillBeSent":
            urls.append(message["params"]["request"]["url"])
    return urls


def _screenshot(browser, clip: dict | None = None) -> np.ndarray:
    from PIL import Image

    arguments = {"format": "png", "captureBeyondViewport": True}
    if clip:
        arguments["clip"] = {**clip, "scale": 1}
    data = browser.execute_cdp_cmd("Page.captureScreenshot", arguments)["data"]
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB")).astype(int)


def _wait_for(browser, script: str, timeout_s: float = 60.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = browser.execute_script(script)
        if value:
            return value
        time.sleep(0.5)
    raise AssertionError(f"the page never satisfied: {script}")


def test_report_page_in_chromium_without_network(browser, frame_build, tmp_path):
    with open(frame_build / "simulation" / "schedule.csv", newline="", encoding="utf-8") as handle:
        schedule = list(csv.DictReader(handle))
    browser.get((frame_build / "report.html").resolve().as_uri())
    _wait_for(browser, "return window.Plotly && document.querySelectorAll('#gantt .barlayer .point').length > 0")

    drawn = browser.execute_script("return document.querySelectorAll('#gantt .barlayer .point').length")
    in_data = browser.execute_script("return document.getElementById('gantt').data.reduce((n, t) => n + t.y.length, 0)")
    assert drawn == in_data == len(schedule)

    # hovering the first transport bar names its component
    first = browser.execute_script(
        "const g = document.getElementById('gantt'); const c = g.data.findIndex(t => t.name === 'transport');"
        "Plotly.Fx.hover(g, [{curveNumber: c, pointNumber: 0}]); return g.data[c].customdata[0];")
    hover = _wait_for(browser, "return document.querySelector('#gantt .hovertext') && "
                               "document.querySelector('#gantt .hovertext').textContent")
    component = next(row["GlobalId"] for row in schedule if row["Activity"] == "transport" and row["GlobalId"] in first)
    assert component in hover

    assert all(url.startswith(("file:", "data:")) for url in _requests(browser)), _requests(browser)

    from PIL import Image

    page = _screenshot(browser)
    Image.fromarray(page.astype(np.uint8)).save(tmp_path / "report.png")
    assert page.std() > 20, f"the page looks blank (pixel std {page.std():.1f}); see {tmp_path}"
    box = browser.execute_script("const r = document.getElementById('gantt').getBoundingClientRect();"
                                 "return {x: r.left + scrollX, y: r.top + scrollY, width: r.width, height: r.height};")
    gantt = _screenshot(browser, box)
    Image.fromarray(gantt.astype(np.uint8)).save(tmp_path / "gantt.png")
    for task, rgb in TASK_RGB.items():
        pixels = (np.abs(gantt - np.array(rgb)).sum(axis=2) < 12).sum()
        assert pixels > 500, f"the Gantt shows no {task} bars ({pixels} pixels of {rgb}); see {tmp_path}"
    picture = browser.execute_script("const i = document.querySelector('#building img'); return i && i.complete && i.naturalWidth")
    assert picture and picture > 400, "the building's picture is shown"
