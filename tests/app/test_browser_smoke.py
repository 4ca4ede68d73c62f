"""The dashboard loads in a real browser: the smoke test every page test builds on."""

import re

import pytest
from playwright.sync_api import expect

pytestmark = pytest.mark.browser


def test_start_page_shows_the_title_in_the_header(app_page, screenshot):
    # FastListTemplate puts the app's title in its header bar and in the document title.
    expect(app_page.locator("#header")).to_contain_text("lubeviz")
    expect(app_page).to_have_title(re.compile(r"^lubeviz"))
    assert screenshot(app_page, "start_page").stat().st_size > 0


def test_start_page_raises_no_javascript_error(page, app_server):
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(app_server + "/app")
    expect(page.locator("#header")).to_contain_text("lubeviz")
    assert errors == []
