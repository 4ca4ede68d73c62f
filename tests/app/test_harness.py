"""The browser harness itself, on a tiny app (tests/app/widgets_app.py): Panel's DOM is found the way
harness.py says, so a Panel or Bokeh upgrade that moves it fails here rather than in every page test."""

from pathlib import Path

import pytest
from playwright.sync_api import expect

from .harness import (
    AppServerError,
    serve_app,
    set_slider,
    slider_value,
    wait_for_plot_title,
    wait_for_plots,
)

pytestmark = pytest.mark.browser

WIDGETS_APP = Path(__file__).with_name("widgets_app.py")


@pytest.fixture(scope="module")
def widgets_url():
    with serve_app(WIDGETS_APP) as base_url:
        yield f"{base_url}/{WIDGETS_APP.stem}"


def test_helpers_drive_slider_text_select_button_and_read_plot_titles(page, widgets_url):
    page.goto(widgets_url)
    wait_for_plots(page)
    assert slider_value(page, "Supply (ml/min)") == 400.0
    set_slider(page, "Supply (ml/min)", 730)
    assert slider_value(page, "Supply (ml/min)") == 730.0
    wait_for_plot_title(page, "Curve at Q = 730 ml/min")
    label = page.get_by_label("Label")
    label.fill("run 2")
    label.press("Enter")  # a TextInput sends its value on Enter or blur
    page.get_by_label("Bearing").select_option("Bearing 2")
    page.get_by_role("button", name="Run").click()
    expect(page.get_by_text("ran run 2 on Bearing 2")).to_be_visible()


def test_set_slider_refuses_a_value_outside_the_range(page, widgets_url):
    page.goto(widgets_url)
    wait_for_plots(page)
    with pytest.raises(ValueError, match="outside its range"):
        set_slider(page, "Supply (ml/min)", 900)


def test_a_server_that_exits_reports_its_output():
    with (pytest.raises(AppServerError, match=r"(?s)exited with code.*--no-such-option"),
          serve_app(WIDGETS_APP, extra_args=("--no-such-option",))):
        pass
