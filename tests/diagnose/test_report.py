"""The diagnosis report: one self-contained HTML file (no network, no JavaScript, inline SVG figures)."""

from __future__ import annotations

import dataclasses
from html.parser import HTMLParser

import numpy as np
import pytest

from lubeviz.diagnose import diagnose
from lubeviz.diagnose.loop import cost_map
from lubeviz.diagnose.report import report_html, residual_svg, write_report
from lubeviz.effects import ProbeRotation, Unbalance2, parse_effect
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.identify.forward.measured import measure
from lubeviz.model.machine import load_machine
from lubeviz.units import M3S_PER_MLMIN

TRUE_MLMIN = (420.0, 600.0)
EVIL = "<b>&evil</b>.csv"


class Tags(HTMLParser):
    """Counts start tags and collects every attribute value and text, failing on unbalanced SVG."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.starts: dict[str, int] = {}
        self.attributes: list[str] = []
        self.text: list[str] = []
        self.open_svg = 0

    def handle_starttag(self, tag, attrs):
        self.starts[tag] = self.starts.get(tag, 0) + 1
        self.attributes += [v or "" for _, v in attrs]
        self.open_svg += tag == "svg"

    def handle_endtag(self, tag):
        self.open_svg -= tag == "svg"

    def handle_data(self, data):
        self.text.append(data)


@pytest.fixture(scope="module")
def diagnosed():
    """A record with the plane-1 probes turned 5 degrees, diagnosed against two candidate effects."""
    machine = load_machine()
    chain = ForwardChain(machine, machine.operating_speed, machine.center_nodes)
    effect = parse_effect("probe_rotation:plane=1,angle_deg=5").hold()
    theta = np.array(TRUE_MLMIN) * M3S_PER_MLMIN
    record = simulate(chain.with_effects((effect,)), theta, snr_db=12.0, rng=np.random.default_rng(7))
    record = dataclasses.replace(record, source=EVIL)
    measured = measure(record)
    d = diagnose(chain, measured, candidates=(ProbeRotation, Unbalance2),
                 truth={"q_mlmin": list(TRUE_MLMIN), "effect": effect.spec()})
    return d, record, chain, measured


def parse(text: str) -> Tags:
    p = Tags()
    p.feed(text)
    p.close()
    return p


def test_report_is_self_contained_html_with_svg_figures(diagnosed):
    d, record, chain, measured = diagnosed
    text = report_html(d, record=record, machine_name="paper machine", bearing_nodes=(6, 20))
    tags = parse(text)
    assert tags.starts.get("html") == 1 and tags.starts.get("body") == 1
    assert tags.starts.get("svg", 0) >= 2 and tags.open_svg == 0
    assert "http" not in text.lower()  # nothing to fetch: no external stylesheet, font, script or image
    assert "script" not in tags.starts and "img" not in tags.starts and "link" not in tags.starts


def test_report_names_the_added_effect_and_both_flows(diagnosed):
    d, record, *_ = diagnosed
    assert d.added is not None and d.added.label == "probe_rotation[plane=1]"
    text = "".join(parse(report_html(d, record=record)).text)
    assert "the probes of plane 1 turned" in text  # the effect named in words ...
    assert "probe_rotation[" not in text and "angle_deg" not in text  # ... never by its code label or parameter
    assert "chi2" not in text and "+-" not in text and "χ²" in text  # the command line's ASCII written as signs
    assert "The probe pair of plane 1 sits" in text  # the effect's story, in words
    for fit in (d.before, d.after):
        for k in range(2):
            assert f"{fit.values[k] / M3S_PER_MLMIN:.0f} ± " in text
    assert "starved" in text and "over-supplied" in text  # 420 and 600 ml/min against Q_T ≈ 545
    assert "lubeviz 0." in text and "75 Hz" in text


def test_report_carries_the_work_order_typed_on_the_page_as_written(diagnosed):
    from lubeviz.diagnose.report import WORK_ORDER_FIELDS

    d, record, *_ = diagnosed
    typed = {"asset": "P-101 B <feed> pump", "location": "unit 2 & pump house", "operator": "A. Engineer",
             "comment": "line 1\nline 2 <script>x</script>"}
    doc = report_html(d, record=record, work_order=typed)
    text = "".join(parse(doc).text)
    for key, head in WORK_ORDER_FIELDS:
        assert head in text
    assert "P-101 B <feed> pump" in text and "unit 2 & pump house" in text and "A. Engineer" in text
    assert "<script>" not in doc and "line 1<br>line 2" in doc  # escaped, its line breaks kept
    assert text.index("P-101 B") < text.index("What to do")  # at the top, where a work order is read
    empty = report_html(d, record=record, work_order={"asset": "  ", "comment": ""})
    assert "Asset / tag" not in empty and "Comment" not in "".join(parse(empty).text)


def test_the_report_s_file_name_comes_from_the_record_and_the_date():
    import datetime as dt

    from lubeviz.diagnose.report import report_file_name

    day = dt.date(2026, 11, 29)
    assert report_file_name("pump-7 inboard.csv", day) == "lubeviz-pump-7-inboard-2026-11-29.html"
    assert report_file_name("C:/runs/../x<y>.npz", day) == "lubeviz-x-y-2026-11-29.html"  # no path, no odd character
    assert report_file_name(None, day) == "lubeviz-record-2026-11-29.html"
    assert len(report_file_name("r" * 500 + ".csv", day)) < 100


def test_report_escapes_text_from_the_record(diagnosed):
    d, record, *_ = diagnosed
    text = report_html(d, record=record, title="Pump <2> & motor")
    assert EVIL not in text and "<b>&evil" not in text
    assert "&lt;b&gt;&amp;evil&lt;/b&gt;.csv" in text
    assert "Pump &lt;2&gt; &amp; motor" in text
    assert "<b>&evil</b>.csv" in "".join(parse(text).text)  # it reads back as the file's name


def test_report_draws_the_maps_when_given(diagnosed, tmp_path):
    d, record, chain, measured = diagnosed
    grid = cost_map(chain, measured, n=12)
    path = write_report(d, tmp_path / "report.html", record=record,
                        maps=[("plain model", grid, [("plain fit", d.before.paths[-1], "#999")])])
    html = path.read_text(encoding="utf-8")
    tags = parse(html)
    assert tags.starts["svg"] >= 3 and tags.starts["polyline"] >= 1
    # the Diagnose page's colours (viridis reversed): its best cell yellow, its worst dark violet
    assert 'fill="#fde725"' in html and 'fill="#440154"' in html


def test_residual_bars_mark_the_two_sigma_band():
    svg = residual_svg(["fb1", "phi1"], np.array([-8.0, 50.0]), np.array([0.3, -0.5]))
    tags = parse(svg)
    assert tags.starts["rect"] >= 5  # band + 4 bars (+ legend)
    assert "±2σ" in "".join(tags.text) and "+50.0" in "".join(tags.text)  # a cut bar keeps its value


def test_report_tells_a_rival_pair_in_words_and_keeps_the_name(diagnosed):
    """A pair that fits nearly as well as the named effect (`Diagnosis.rivals`) is told in an engineer's words, the
    named effect kept as the report's reading; the JSON carries the labels."""
    from lubeviz.diagnose import diagnosis_dict

    d, record, *_ = diagnosed
    rival = "viscosity[bearing=both] + clearance[bearing=2]"
    text = "".join(parse(report_html(dataclasses.replace(d, rivals=(rival,)), record=record)).text)
    assert "Two faults at once fit nearly as well" in text
    assert "the oil's viscosity in every bearing with the clearance of bearing 2" in text and "clearance[" not in text
    assert "The model needed the probes of plane 1 turned" in text
    assert "Two faults at once" not in "".join(parse(report_html(d, record=record)).text)
    assert diagnosis_dict(dataclasses.replace(d, rivals=(rival,)))["rivals"] == [rival]
