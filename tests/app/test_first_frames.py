"""The Rotor page's plots are made once, with the first response as their first frame (issue 38: the tab's first
draw took 5.2 s, each plot built from an empty frame and then updated, and drawn twice in the browser), and no
response's plots stay under an error (issue 38: "no stale plot under an error anywhere"); the Bearing page's fields
and profiles likewise with the first film."""

from __future__ import annotations


import holoviews as hv
import panel as pn
from bokeh.document import Document

from lubeviz.app import resources
from tests.app.threads import run_coro
from lubeviz.app.bearing_page import BearingPage
from lubeviz.app.rotor_page import RotorPage
from lubeviz.model.operating import operating_point


def _dynamic_maps(page):
    return [p.object for p in page._layout.select(pn.pane.HoloViews) if isinstance(p.object, hv.DynamicMap)]


def _started(page):
    page.__panel__().get_root(Document())  # the tab shown: its models made
    run_coro(page.start())
    return page


def test_before_the_first_response_the_page_says_what_is_coming_and_holds_no_empty_plot():
    m = resources.machine()
    page = RotorPage(m, operating_point(m))
    page.__panel__().get_root(Document())
    assert _dynamic_maps(page) == []
    assert "Computing the rotor's response" in page._plots.objects[0].object


def test_the_plots_first_frames_are_the_first_response():
    m = resources.machine()
    page = _started(RotorPage(m, operating_point(m)))
    maps = _dynamic_maps(page)
    # the machine, the orbit, its signals, the spectrum, the modes and one centreline per bearing
    assert len(maps) == 5 + len(m.bearings)
    assert page._pipe.data is not None
    for dm in maps:
        assert len(dm.data) == 1  # one frame made: the response's, not an empty one before it
        (frame,) = dm.data.values()
        assert frame is not None
    spectrum = page._spectrum(page._pipe.data)
    assert "Full spectrum at node 6" in spectrum.opts.get().kwargs["title"]


def test_an_error_after_a_response_leaves_no_plot_of_it_on_the_page():
    m = resources.machine()
    page = _started(RotorPage(m, operating_point(m)))
    assert page._summary.object
    page._fail(ValueError("the films could not be solved"))
    assert page._error.visible and "could not be solved" in page._error.object
    assert page._pipe.data is None and page._summary.object == ""


def test_the_bearing_page_puts_its_fields_and_profiles_on_with_the_first_film():
    m = resources.machine()
    page = BearingPage(m, operating_point(m))
    page.__panel__().get_root(Document())
    assert "Solving the film" in page._fields.objects[0].object and page._profiles.objects == []

    async def first_film():
        await page._threshold(0, page.speed)
        await page._show_current()

    run_coro(first_film())
    assert page._fields.objects == page._field_panes and page._profiles.objects == page._profile_panes
    assert page._frame_pipe.data is page._frame and page._detail_pipe.data is page._frame
    for pane in page._field_panes + page._profile_panes:
        (frame,) = pane.object.data.values()  # one frame made: the film's
        assert frame is not None
    title = page._profile_pressure(page._frame).opts.get().kwargs["title"]
    assert f"at Q = {page._frame.q / 1e-6 * 60:.0f} ml/min" in title  # the first frame is the film at its flow


def test_an_error_before_the_first_result_does_not_say_one_is_coming():
    m = resources.machine()
    rotor = RotorPage(m, operating_point(m))
    rotor._fail(ValueError("no tables"))
    assert "Computing" not in rotor._plots.objects[0].object and "No response" in rotor._plots.objects[0].object
    bearing = BearingPage(m, operating_point(m))
    bearing._fail(ValueError("no film"))
    assert "Solving" not in bearing._fields.objects[0].object and "No film" in bearing._fields.objects[0].object
