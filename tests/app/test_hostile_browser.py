"""Hostile records in a real browser (Chromium driven by Playwright; see harness.py): issue 34, items 1 and 8.

What a hostile but fair user does: drop records whose every text field quoted in a message or shown on the
page (units, machine, node, speed, a column name, an unknown key and its value, a set name, the file name)
holds `<img src=x onerror=...>` or `<script>...</script>`, on the Identify and the Diagnose pages. No script
runs (`window.__xss` stays undefined), no such element enters the page, and the text is shown as written.
A valid record carrying the payload in an unknown key loads, and its reader's warnings are shown.
A client that bypasses the browser's size limit is refused by the server: test_hostile.py (the chunks).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import expect

from tests.app.harness import open_tab

pytestmark = pytest.mark.browser

SLOW_MS = 240_000  # a cold machine builds the coefficient tables first
IMG = '<img src=x onerror="window.__xss=1">'
SCRIPT = "<script>window.__xss=1</script>"
FILE_NAME = f"{IMG}.csv"  # a file name cannot hold the script's '/'
# (field, how the good record's text is changed, what the refusal says)
REFUSED = [
    ("units", ("# units: m", f"# units: {IMG}"), "units"),
    ("machine", ("# machine: paper_machine.toml", f"# machine: {IMG}"), "machine"),
    ("machine-script", ("# machine: paper_machine.toml", f"# machine: {SCRIPT}"), "machine"),
    ("node", ("# node1: 6", f"# node1: {IMG}"), "node1"),
    ("speed", ("# speed_hz: 75.0", f"# speed_hz: {SCRIPT}"), "speed_hz"),
    ("column", ("t,x1,y1,x2,y2", f"t,x1,y1,x2,{IMG}"), "missing column"),
]
PAGES = {  # tab, dropper, message, record box, warnings box
    "Identify": ("lubeviz-upload", ".lubeviz-upload-error", ".lubeviz-record-info", ".lubeviz-record-warnings"),
    "Diagnose": ("lubeviz-diagnose-upload", ".lubeviz-diagnose-error", ".lubeviz-diagnose-record",
                 ".lubeviz-diagnose-record-warnings"),
}


@pytest.fixture(scope="module")
def hostile(tmp_path_factory) -> dict[str, Path]:
    """The refused variants and the valid record with the payload in an unknown key, each under FILE_NAME
    in its own folder."""
    from lubeviz.cli.main import main

    root = tmp_path_factory.mktemp("hostile")
    good = root / "good.csv"
    assert main(["simulate", "--q1-mlmin", "400", "--q2-mlmin", "500", "--duration-s", "1", "--seed", "3",
                 "-o", str(good)]) == 0
    text = good.read_text()
    files = {}
    for field, (old, new), _ in REFUSED:
        assert old in text, old
        (root / field).mkdir()
        files[field] = root / field / FILE_NAME
        files[field].write_text(text.replace(old, new, 1))
    (root / "valid").mkdir()
    files["valid"] = root / "valid" / FILE_NAME
    files["valid"].write_text(text.replace("# units: m", f"# units: m\n# {IMG}: {SCRIPT}\n# set: {IMG}\n"
                                                         f"# unitz: {SCRIPT}", 1))
    return files


def assert_no_script_ran(page):
    page.wait_for_timeout(300)  # an <img onerror> fires once its load has failed
    assert page.evaluate("() => typeof window.__xss") == "undefined"
    expect(page.locator('img[src="x"]')).to_have_count(0)  # CSS locators pierce Bokeh's shadow roots
    expect(page.locator("script", has_text="window.__xss")).to_have_count(0)


@pytest.mark.parametrize("tab", list(PAGES))
def test_html_in_a_record_is_shown_as_text_and_never_runs(app_page, hostile, tab, screenshot):
    page = app_page
    dropper, message_css, info_css, warnings_css = PAGES[tab]
    open_tab(page, tab)
    message, info = page.locator(message_css), page.locator(info_css)
    expect(page.locator(f".{dropper} input[type=file]")).to_be_attached(timeout=SLOW_MS)
    for field, (_, new), said in REFUSED:
        page.locator(f".{dropper} input[type=file]").set_input_files(str(hostile[field]))
        expect(message, field).to_be_visible(timeout=30_000)
        expect(message, field).to_contain_text("was not loaded", timeout=30_000)
        expect(message, field).to_contain_text(said, timeout=30_000)
        assert_no_script_ran(page)
        expect(message, field).to_contain_text(f"{FILE_NAME} was not loaded")
        expect(message, field).to_contain_text(new.split(": ", 1)[-1].split(",")[-1])  # the value, as written
    screenshot(page, f"hostile_{tab.lower()}_refused")

    page.locator(f".{dropper} input[type=file]").set_input_files(str(hostile["valid"]))
    expect(message).to_be_hidden(timeout=30_000)
    expect(info).to_contain_text(FILE_NAME, timeout=30_000)
    warnings = page.locator(warnings_css)
    expect(warnings).to_be_visible()
    expect(warnings).to_contain_text(f"unknown key '{IMG}' ignored")
    expect(warnings).to_contain_text("unknown key 'unitz' ignored; did you mean 'units'?")
    assert_no_script_ran(page)
    if tab == "Identify":  # the result names the record too
        page.get_by_role("button", name="Identify the supply flows").click()
        result = page.locator(".lubeviz-result")
        expect(result).to_contain_text(f"Identified supply flows of {FILE_NAME}", timeout=SLOW_MS)
        assert_no_script_ran(page)
    screenshot(page, f"hostile_{tab.lower()}_loaded")



def _frames(sock):
    """(opcode, payload) of each websocket frame the server sends on `sock` (unmasked, as servers send)."""
    import struct

    def read(n):
        data = b""
        while len(data) < n:
            more = sock.recv(n - len(data))
            if not more:
                raise ConnectionError("closed")
            data += more
        return data

    while True:
        first, second = read(2)
        length = second & 0x7F
        if length == 126:
            length = struct.unpack("!H", read(2))[0]
        elif length == 127:
            length = struct.unpack("!Q", read(8))[0]
        yield first & 0x0F, read(length)


def _announce(base_url: str, token: str, size: int, wait_s: float):
    """Open the app's websocket by hand, send only the header of a binary frame of `size` bytes and return
    the close code the server sends within `wait_s` (None: it waits for the payload)."""
    import os
    import socket
    import struct

    host, port = base_url.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=wait_s) as sock:
        sock.sendall((f"GET /app/ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                      f"Connection: Upgrade\r\nSec-WebSocket-Key: bHViZXZpei10ZXN0LWtleQ==\r\n"
                      f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: bokeh, {token}\r\n"
                      f"Origin: {base_url}\r\n\r\n").encode())
        reply = b""
        while b"\r\n\r\n" not in reply:
            reply += sock.recv(4096)
        assert reply.startswith(b"HTTP/1.1 101"), reply[:200]
        sock.sendall(struct.pack("!BBQ", 0x82, 0x80 | 127, size) + os.urandom(4))  # FIN, binary, masked
        try:
            for opcode, payload in _frames(sock):
                if opcode == 0x8:
                    return struct.unpack("!H", payload[:2])[0]
        except (TimeoutError, socket.timeout):
            return None
        except ConnectionError:
            return "closed without a close frame"


def test_the_server_takes_no_websocket_message_beyond_its_limit(app_server):
    """`panel serve ... --websocket-max-message-size` (README, harness): a frame announcing one byte more than
    the limit is refused on its header (close code 1009, message too big), before any of its bytes are held;
    one announcing the limit is awaited."""
    import re
    import urllib.request

    from lubeviz.app.widgets import UPLOAD_CHUNK_BYTES, WEBSOCKET_MAX_MESSAGE_BYTES

    assert WEBSOCKET_MAX_MESSAGE_BYTES > 4 / 3 * UPLOAD_CHUNK_BYTES  # an upload's chunk passes, even base64-encoded

    def token():
        with urllib.request.urlopen(app_server + "/app", timeout=120) as response:
            return re.search(r'"token"\s*:\s*"([^"]+)"', response.read().decode()).group(1)

    assert _announce(app_server, token(), WEBSOCKET_MAX_MESSAGE_BYTES + 1, wait_s=10.0) == 1009
    assert _announce(app_server, token(), WEBSOCKET_MAX_MESSAGE_BYTES, wait_s=2.0) is None
