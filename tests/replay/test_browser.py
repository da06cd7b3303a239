"""The replay in a real browser: Rerun's web viewer on 127.0.0.1, headless Chromium, WebGL via SwiftShader.

The built-in steel frame and the shared model with the most elements (MULTICOM-Prefab, drawn as
boxes by state: it opens within a minute of a tiny recording, docs/evidence/replay.md). Two times on
the timeline (early in the build and its end), a screenshot at each: the 3D view must not be blank,
and it must change where the structure grew (more of it coloured as assembled at the end). A browser
without WebGL fails the test rather than passing on a blank canvas. Every request the page
makes is recorded: none may leave 127.0.0.1 (Rerun's analytics are stopped by the page's policy).
"""

from __future__ import annotations

import base64
import io
import shutil
import time

import numpy as np
import pytest

pytestmark = pytest.mark.browser

#: Window of the headless browser (CSS pixels) and where the viewer lays out its parts in it.
WINDOW = (1280, 800)
#: A column through the time panel's time field and one right of it (screenshot pixels), and the 3D
#: view (x0, y0, x1; it ends above the time field).
TIME_FIELD_X, RIGHT_OF_FIELD_X = 390, 600
VIEW_3D = (10, 60, 740)
#: Seconds to wait for the viewer to take a typed time before typing it again.
RETYPE_S = 15.0


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def chromium_session(webdriver):
    """A headless Chromium (WebGL through SwiftShader, :data:`WINDOW`) that logs every request the page
    begins and what the page's Content-Security-Policy stopped (``window._blocked``); None without
    Debian's chromium and chromium-driver. ``webdriver``: selenium's module (bench/replay_load.py uses it too)."""
    from selenium.webdriver.chrome.service import Service

    binary, driver = _chromium(), shutil.which("chromedriver")
    if binary is None or driver is None:
        return None
    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for argument in ("--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                     f"--window-size={WINDOW[0]},{WINDOW[1]}", "--force-device-scale-factor=1",
                     # nothing but 127.0.0.1 can be reached, should the page's policy let a request through
                     "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"performance": "ALL"})  # every request the page makes
    session = webdriver.Chrome(service=Service(driver), options=options)
    # what the page's Content-Security-Policy stopped, as the page itself sees it; and no console.debug:
    # the viewer's shader translator writes some 12,000 debug lines while it starts, each one handed to
    # chromedriver (steel frame: 29 -> 12 browser CPU seconds until its first data; errors still show)
    session.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": (
        "window._blocked = []; document.addEventListener('securitypolicyviolation', "
        "e => window._blocked.push(e.blockedURI)); console.debug = () => {};")})
    return session


@pytest.fixture
def browser():
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed (pip install selenium)")
    session = chromium_session(webdriver)
    if session is None:
        pytest.skip("Debian's chromium and chromium-driver are not installed (scripts/setup.sh installs them)")
    try:
        yield session
    finally:
        session.quit()


def _screenshot(browser) -> np.ndarray:
    from PIL import Image

    # CDP's capture waits less on a busy renderer than WebDriver's screenshot command
    data = browser.execute_cdp_cmd("Page.captureScreenshot", {"format": "png"})["data"]
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB")).astype(int)


def _varint(data: bytes, index: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = data[index]
        index += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, index


def _fields(data: bytes) -> dict[int, list]:
    """The top-level fields of a protobuf message: number -> [int or bytes] (enough for one path)."""
    fields: dict[int, list] = {}
    index = 0
    while index < len(data):
        key, index = _varint(data, index)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, index = _varint(data, index)
        elif wire == 2:
            length, index = _varint(data, index)
            value, index = data[index:index + length], index + length
        elif wire in (1, 5):
            value, index = data[index:index + (8 if wire == 1 else 4)], index + (8 if wire == 1 else 4)
        else:
            raise ValueError(f"wire type {wire}")
        fields.setdefault(number, []).append(value)
    return fields


def _state(browser, *path: int) -> float | None:
    """A time (s) in the viewer's Viewer Control state (GetStateResponse, nanoseconds), by field path;
    None while it has none. (3, 3, 3, 1): the active recording's time cursor; (3, 2, 3, 2): the end of
    its active timeline, i.e. the latest time the viewer has received."""
    state = browser.execute_script("return window._handle ? Array.from(window._handle.viewer_state()) : null")
    try:
        message = bytes(state)
        for number in path[:-1]:
            message = _fields(message)[number][0]
        return _fields(message)[path[-1]][0] / 1e9
    except (TypeError, KeyError, IndexError, ValueError):
        return None


def _cursor_s(browser) -> float | None:
    return _state(browser, 3, 3, 3, 1)


def _type_time(browser, seconds: float) -> None:
    """Type a time into the time panel's field, as a user would."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    canvas = browser.find_element("id", "the_canvas_id")
    width, height = canvas.size["width"], canvas.size["height"]
    # the canvas fills the window below nothing else, so screenshot rows are canvas rows
    x, y = TIME_FIELD_X, time_field_y(_screenshot(browser))
    ActionChains(browser).move_to_element_with_offset(canvas, x - width // 2, y - height // 2).double_click().perform()
    time.sleep(0.5)
    (ActionChains(browser).key_down(Keys.CONTROL).send_keys("a").key_up(Keys.CONTROL)
     .send_keys(f"{seconds:.3f}s").send_keys(Keys.ENTER).perform())


def _wait_until_loaded(browser, makespan_s: float, timeout_s: float = 420.0) -> None:
    """Until the whole replay is in: the viewer's timeline reaches the end of the build."""
    deadline = time.monotonic() + timeout_s
    end = None
    while time.monotonic() < deadline:
        end = _state(browser, 3, 2, 3, 2)
        if end is not None and abs(end - makespan_s) < 0.01:
            return
        time.sleep(0.5)
    raise AssertionError(f"the web viewer did not load the whole replay in {timeout_s:.0f} s (its timeline reaches "
                         f"{end} s, the build {makespan_s} s)")


def _at(browser, seconds: float) -> bool:
    cursor = _cursor_s(browser)
    return cursor is not None and abs(cursor - seconds) < 0.01


def _go_to(browser, seconds: float, timeout_s: float = 90.0) -> np.ndarray:
    """Set the timeline to ``seconds``, check the viewer took it, and return a screenshot once it has
    redrawn: two screenshots in a row showing the same 3D view (each waits for a new frame), at most 8."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        # typed again if a busy viewer lost the keys (it answers in a frame or two when it took them)
        _type_time(browser, seconds)
        retype = time.monotonic() + RETYPE_S
        while time.monotonic() < min(retype, deadline) and not _at(browser, seconds):
            time.sleep(0.5)
        if _at(browser, seconds):
            break
    else:
        raise AssertionError(f"the viewer's time is {_cursor_s(browser)} s, not the {seconds} s typed into it")
    shot = _screenshot(browser)
    for _ in range(7):
        again = _screenshot(browser)
        if np.array_equal(_view(shot), _view(again)):
            break
        shot = again
    return again


def _requests(browser) -> list[tuple[str, str | None]]:
    """(url, why it failed: Chromium's blockedReason or None) of every request the page began."""
    import json

    began, failed = {}, {}
    for entry in browser.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message["method"] == "Network.requestWillBeSent":
            began[message["params"]["requestId"]] = message["params"]["request"]["url"]
        elif message["method"] == "Network.loadingFailed":
            failed[message["params"]["requestId"]] = message["params"].get("blockedReason")
    return [(url, failed.get(request)) for request, url in began.items()]


def time_field_y(image: np.ndarray) -> int:
    """The middle row of the time panel's time field in a screenshot. The viewer lays its panels out anew
    on each start, and the time panel's height varies by some 14 px between starts (CI, 2026-11-28), so
    the field is found, not assumed: the lowest pair of light-grey rows 18-24 px apart (the field's top
    and bottom borders) that cross :data:`TIME_FIELD_X` but not :data:`RIGHT_OF_FIELD_X` (panel
    separators cross both) in the lower half of the window."""
    grey = [y for y in range(image.shape[0] // 2, image.shape[0])
            if 200 < image[y, TIME_FIELD_X].mean() < 235 and image[y, RIGHT_OF_FIELD_X].mean() > 250]
    pairs = [(top, bottom) for top in grey for bottom in grey if 18 <= bottom - top <= 24]
    if not pairs:
        raise AssertionError("the viewer's time field is not where the time panel should be (x "
                             f"{TIME_FIELD_X}, lower half of a {image.shape[1]} x {image.shape[0]} window)")
    top, bottom = pairs[-1]
    return (top + bottom) // 2


def _view(image: np.ndarray) -> np.ndarray:
    x0, y0, x1 = VIEW_3D
    return image[y0:time_field_y(image) - 20, x0:x1]


def _assembled_green(view: np.ndarray) -> np.ndarray:
    r, g, b = view[..., 0], view[..., 1], view[..., 2]
    return (g > r + 40) & (g > b + 40)


@pytest.fixture(params=["steel frame", "MULTICOM-Prefab"])
def replay_to_open(request):
    """(rrd, summary): the built-in steel frame's replay (each element its mesh), and that of the shared
    model with the most elements, MULTICOM-Prefab (boxes by state; skipped without ../shared)."""
    return request.getfixturevalue("frame_pair_replay" if request.param == "steel frame" else "prefab_pair_replay")


def test_web_viewer_shows_the_structure_growing(browser, replay_to_open, tmp_path):
    from bimrobot.replay.serve import serve_web

    rrd, summary = replay_to_open
    with serve_web(rrd) as viewer:
        browser.get(viewer.url + "&persist=0")
        webgl = browser.execute_script("const c = document.createElement('canvas'); return !!(c.getContext('webgl2') || c.getContext('webgl'))")
        assert webgl, "this Chromium has no WebGL (SwiftShader missing?): the replay cannot be checked in it"
        _wait_until_loaded(browser, summary["makespan_s"])
        early, late = round(0.05 * summary["makespan_s"], 1), summary["makespan_s"]
        first = _go_to(browser, early)
        second = _go_to(browser, late)
        requests = _requests(browser)
        blocked = browser.execute_script("return window._blocked")
    from urllib.parse import urlsplit

    # Rerun's usage analytics: the page would post them to tel.rerun.io; the page's policy stops them in
    # the browser (blocked by csp, not merely unresolved), and nothing else leaves 127.0.0.1 either
    assert any(urlsplit(url).hostname == "127.0.0.1" for url, _ in requests)
    leaving = [(url, why) for url, why in requests if urlsplit(url).hostname != "127.0.0.1" and not url.startswith(("data:", "blob:"))]
    assert all(why == "csp" for _, why in leaving), f"requests that left 127.0.0.1: {leaving}"
    assert any(urlsplit(url).hostname == "tel.rerun.io" for url in blocked), f"the policy blocked {blocked}"
    assert all(urlsplit(url).hostname not in (None, "127.0.0.1") for url in blocked)
    from PIL import Image

    Image.fromarray(first.astype(np.uint8)).save(tmp_path / "early.png")
    Image.fromarray(second.astype(np.uint8)).save(tmp_path / "late.png")
    view1, view2 = _view(first), _view(second)
    # not blank: a rendered scene has light and dark, a blank canvas is one colour
    assert view1.std() > 12 and view2.std() > 12, f"blank 3D view (pixel std {view1.std():.1f}, {view2.std():.1f}); see {tmp_path}"
    changed = np.abs(view1 - view2).sum(axis=2) > 60
    assert changed.mean() > 0.01, f"the two times look the same; see {tmp_path}"
    grown = _assembled_green(view2) & ~_assembled_green(view1)
    assert grown.sum() > 2000, f"the end of the build shows no more assembled (green) structure than its start; see {tmp_path}"
    # where the picture changed, it is mostly because the structure grew there
    assert (grown & changed).sum() > 0.3 * grown.sum()
    # the 3D view is framed on the building: the assembled building spans most of its height or width
    # (Prefab's eye once left it a third of the view either way; now 0.77, the frame 0.87)
    assert _span(_assembled_green(view2)) > 0.6, f"the building fills {_span(_assembled_green(view2)):.2f} of the 3D view; see {tmp_path}"


def _span(mask: np.ndarray) -> float:
    """The larger share of the view's width or height that ``mask``'s pixels span (0.5 to 99.5 percentile)."""
    rows, columns = np.nonzero(mask)
    if len(rows) == 0:
        return 0.0
    spans = [np.ptp(np.percentile(x, [0.5, 99.5])) / size for x, size in ((columns, mask.shape[1]), (rows, mask.shape[0]))]
    return float(max(spans))
