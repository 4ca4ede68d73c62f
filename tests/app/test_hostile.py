"""Hostile input on the dashboard without a browser (issue 34, items 1, 8 and 9): text from a file is shown,
never run; the reader's warnings are shown; an upload beyond the limit is refused by the server as its
chunks arrive; the server-wide caches stay bounded whatever speeds the records carry.

The pages are built in this process and fed an upload as the dropper reports it; every Markdown pane is
rendered the way Panel sends it to the browser (its own markdown-it parser) and searched for HTML tags.
The same cases in a real browser: test_hostile_browser.py.
"""

from __future__ import annotations

import html
import re
from pathlib import Path
from types import SimpleNamespace

import panel as pn
import pytest

from lubeviz.app import resources
from lubeviz.app.text import FILE_LABEL_CHARS, file_label, plain, without_upload_dirs
from lubeviz.app.widgets import RecordDropper
from tests.app.threads import run_coro

IMG = '<img src=x onerror="window.__xss=1">'
SCRIPT = "<script>window.__xss=1</script>"
MARKDOWN = "[click](javascript:alert(1)) ![i](x) `code` **bold** | cell | $$x$$ _em_ :smile:"
PAYLOADS = (IMG, SCRIPT, MARKDOWN, "a\n# heading\n- item\n<img src=x\nonerror=alert(1)>")
TAGS = re.compile(r"<\s*(img|script|a|code|em|h1|li|svg|iframe)\b", re.IGNORECASE)  # in text shown as written
# on a page, whose own text has headings, code and links: a tag a payload could bring, or an event handler
HOSTILE = re.compile(r"<\s*(img|script|svg|iframe|object|embed)\b|<[^>]*\son\w+\s*=", re.IGNORECASE)


_run = run_coro


def rendered(markdown: str) -> str:
    """The HTML a Markdown pane sends to the browser for `markdown` (Panel's parser, its settings)."""
    return html.unescape(pn.pane.Markdown(markdown)._transform_object(markdown)["object"])


def visible(markup: str) -> str:
    """The text a reader sees in `markup` (tags dropped, references decoded)."""
    return html.unescape(re.sub(r"<[^>]*>", "", markup))


@pytest.mark.parametrize("payload", PAYLOADS)
def test_plain_text_in_markdown_renders_as_written_and_no_tag(payload):
    out = rendered(f"**Record {plain(payload)}** | a |\n|---|---|\n| {plain(payload)} | b |")
    assert not TAGS.search(out), out
    shown = " ".join(payload.split())  # line breaks become spaces, nothing else changes
    assert visible(out).count(shown) == 2, out


def test_file_label_is_the_base_name_shortened_with_its_suffix():
    long = "r" * 300 + ".csv"
    assert file_label("/tmp/upload/" + long) == "r" * (FILE_LABEL_CHARS - 5) + "….csv"
    assert file_label("C:\\Users\\me\\run 3.csv") == "run 3.csv"
    assert file_label("a\x00b.csv") == "a?b.csv"
    assert len(file_label("😀" * 100 + ".csv").encode("utf-8")) <= 200  # a file system's 255-byte name limit


def test_upload_dirs_are_taken_out_of_a_message():
    import tempfile

    tmp = tempfile.gettempdir()
    assert without_upload_dirs(f"cannot read {tmp}/lubeviz-upload-k2_x9/run.mat: bad") == "cannot read run.mat: bad"


# --- the pages ------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def good_csv(tmp_path_factory) -> str:
    """A valid record (75 Hz, 10 kHz, 1 s) written by the CLI, as text."""
    from lubeviz.cli.main import main

    path = tmp_path_factory.mktemp("hostile") / "good.csv"
    assert main(["simulate", "--q1-mlmin", "400", "--q2-mlmin", "500", "--duration-s", "1", "--seed", "3",
                 "-o", str(path)]) == 0
    return path.read_text()


def hostile_variants(good: str) -> dict[str, str]:
    """A copy of `good` with the payload in one text field each: every one is refused with the value quoted."""
    return {
        "units": good.replace("# units: m", f"# units: {IMG}"),
        "machine": good.replace("# machine: paper_machine.toml", f"# machine: {IMG}"),
        "node": good.replace("# node1: 6", f"# node1: {IMG}"),
        "speed": good.replace("# speed_hz: 75.0", f"# speed_hz: {SCRIPT}"),
        "column": good.replace("t,x1,y1,x2,y2", f"t,x1,y1,x2,{IMG}"),
    }


def loaded_with_payload_key(good: str) -> str:
    """A valid record whose unknown key and a misspelled key hold the payloads: it loads, with warnings."""
    return good.replace("# units: m", f"# units: m\n# {IMG}: {SCRIPT}\n# unitz: {IMG}")


def page_html(page) -> list[str]:
    return [rendered(p.object or "") for p in page._layout.select(pn.pane.Markdown)]


def build(kind: str):
    from lubeviz.app.session import SessionState

    machine = resources.machine()
    if kind == "identify":
        from lubeviz.app.identify_page import IdentifyPage
        return IdentifyPage(machine, SessionState(name="test"))
    from lubeviz.app.diagnose_page import DiagnosePage
    return DiagnosePage(machine, SessionState(name="test"))


def info(page):
    return page._record_info


@pytest.mark.parametrize("kind", ["identify", "diagnose"])
def test_a_refused_record_quoting_html_shows_it_as_text(kind, good_csv):
    page = build(kind)
    filename = f"{IMG}.csv"
    for field, content in hostile_variants(good_csv).items():
        _run(page._on_upload(SimpleNamespace(new=(filename, content))))
        assert page._message.visible, field
        out = page_html(page)
        assert not any(HOSTILE.search(h) for h in out), (field, [h for h in out if HOSTILE.search(h)])
        message = visible(rendered(page._message.object))
        assert f"{filename} was not loaded" in message and "window.__xss=1" in message, (field, message)


@pytest.mark.parametrize("kind", ["identify", "diagnose"])
def test_a_loaded_record_shows_its_reader_warnings_as_text(kind, good_csv):
    page = build(kind)
    _run(page._on_upload(SimpleNamespace(new=(f"{IMG}.csv", loaded_with_payload_key(good_csv)))))
    assert not page._message.visible, page._message.object
    warnings = page._record_warnings
    assert warnings.visible
    shown = visible(rendered(warnings.object))
    assert f"unknown key '{IMG}' ignored" in shown, shown
    assert "unknown key 'unitz' ignored; did you mean 'units'?" in shown, shown
    assert f"{IMG}.csv" in visible(rendered(info(page).object))
    assert not any(HOSTILE.search(h) for h in page_html(page))


@pytest.mark.parametrize("kind", ["identify", "diagnose"])
def test_a_record_naming_another_machine_is_warned_and_the_page_keeps_its_own(kind, good_csv):
    page = build(kind)
    other = good_csv.replace("# machine: paper_machine.toml", "# machine: test_rig.toml")
    _run(page._on_upload(SimpleNamespace(new=("rig.csv", other))))
    shown = visible(rendered(page._record_warnings.object))
    assert page._record_warnings.visible and "test_rig.toml" in shown and "paper_machine.toml" in shown, shown
    assert Path(page.machine.source).name == "paper_machine.toml"  # not switched
    # the record's own machine, named either way, is no warning
    _run(page._on_upload(SimpleNamespace(new=("same.csv", good_csv.replace(
        "# machine: paper_machine.toml", "# machine: paper_machine")))))
    assert not page._record_warnings.visible, page._record_warnings.object


def test_diagnose_page_shows_no_truth_from_an_uploaded_file(good_csv):
    page = build("diagnose")
    claimed = good_csv.replace("# q1_mlmin: 400", "# q1_mlmin: 999")
    assert "q1_mlmin: 999" in claimed and "synthetic" in claimed  # the metadata claims a truth
    _run(page._on_upload(SimpleNamespace(new=("claims.csv", claimed))))
    shown = visible(rendered(info(page).object))
    assert "claims.csv" in shown and "Truth" not in shown and "999" not in shown, shown
    assert page._truth is None


@pytest.mark.parametrize("kind", ["identify", "diagnose"])
def test_an_over_long_file_name_is_shown_short_and_never_as_a_server_path(kind, good_csv):
    import tempfile

    page = build(kind)
    name = "run-" + "9" * 400 + ".csv"  # longer than a file system takes
    _run(page._on_upload(SimpleNamespace(new=(name, good_csv.replace("# units: m", "# units: furlong")))))
    shown = visible(rendered(page._message.object))
    assert tempfile.gettempdir() not in shown and "lubeviz-upload" not in shown, shown
    assert "furlong" in shown, shown  # the reader's own message, not an OSError about the name
    assert file_label(name) in shown and len(file_label(name)) == FILE_LABEL_CHARS
    _run(page._on_upload(SimpleNamespace(new=(name, good_csv))))
    assert file_label(name) in visible(rendered(info(page).object)) and name not in info(page).object


def test_tables_show_text_cells_as_plain_text():
    import pandas as pd

    from lubeviz.app.text import table_html

    frame = pd.DataFrame({IMG: [IMG, SCRIPT], "rank": [1, 2]})
    markup = table_html(frame, marked=[1])
    assert not HOSTILE.search(markup), markup  # neither a header nor a cell becomes markup
    assert visible(markup).count(IMG) == 2 and SCRIPT in visible(markup)
    assert markup.count('class="beyond"') == 1


# --- the upload limit on the server ------------------------------------------------------------------

def chunk_event(name: str, chunk: int, total: int, data: bytes):
    return SimpleNamespace(event_name="upload_event",
                           data={"name": name, "chunk": chunk, "total_chunks": total, "data": data, "type": ""})


def held_bytes(dropper: RecordDropper) -> int:
    buffered = sum(len(b) for parts in dropper._file_buffer.values() for b in parts)
    return buffered + sum(len(v) for v in dropper.value.values())


def test_the_server_refuses_an_upload_beyond_the_limit_as_its_chunks_arrive():
    limit = 1_000_000
    dropper = RecordDropper(max_file_size="1MB")
    assert dropper.limit_bytes == limit
    refused, uploads = [], []
    dropper.param.watch(lambda e: refused.append(e.new), "refused")
    dropper.param.watch(lambda e: uploads.append(e.new), "upload")
    chunk = b"0" * 300_000
    peak = 0
    for i in range(1, 21):  # 6 MB announced, sent whatever the server says (a scripted client)
        dropper._process_event(chunk_event("big.csv", i, 20, chunk))
        peak = max(peak, held_bytes(dropper))
    assert peak <= limit
    assert held_bytes(dropper) == 0 and not uploads
    assert refused == [("big.csv", 1_200_000)]  # refused at the chunk that passed the limit, once
    assert dropper.rejected
    # a file within the limit arrives whole afterwards
    for i in range(1, 4):
        dropper._process_event(chunk_event("ok.csv", i, 3, chunk))
    assert uploads == [("ok.csv", chunk * 3)] and not dropper.rejected


def test_the_server_keeps_one_upload_at_a_time_and_refuses_malformed_chunks():
    dropper = RecordDropper(max_file_size="1MB")
    refused = []
    dropper.param.watch(lambda e: refused.append(e.new), "refused")
    for k in range(50):  # many uploads started, none finished: only the last one's chunks are held
        dropper._process_event(chunk_event(f"f{k}.csv", 1, 10, b"1" * 90_000))
    assert held_bytes(dropper) == 90_000
    dropper._process_event(chunk_event("f49.csv", 2, 10, "not bytes"))  # type: ignore[arg-type]
    dropper._process_event(chunk_event("f49.csv", 3, 10, b"1" * 10))
    assert refused == [("f49.csv", 90_000)] and held_bytes(dropper) == 0


# --- bounded caches --------------------------------------------------------------------------------------

def test_caches_keyed_by_speed_stay_bounded(monkeypatch):
    """100 records at 100 speeds through every speed-keyed store (its numerics replaced by stand-ins)."""
    from lubeviz.film import equilibrium, explore
    from lubeviz.identify.tables import cache
    from lubeviz.identify.forward import chain
    from lubeviz.identify.forward import model as forward

    machine = resources.machine()
    # fresh stores (monkeypatch puts the server's back afterwards)
    for store in ("_TABLES", "_MODELS", "_CHAINS", "_VIEWS", "_THRESHOLDS", "_FRAMES", "_MEMO"):
        monkeypatch.setattr(resources, store, resources.Recent(getattr(resources, store).size))
    monkeypatch.setattr(cache, "machine_tables", lambda m, omega, progress=None: ("tables", omega))
    monkeypatch.setattr(forward, "ForwardModel", lambda m, t, nodes, rotor=None: ("model", t, nodes))
    monkeypatch.setattr(chain, "ForwardChain", lambda m, speed, nodes, **kw: SimpleNamespace(sources=()))
    monkeypatch.setattr(equilibrium, "flooded_threshold", lambda b, omega, load: (1e-5, None))
    monkeypatch.setattr(explore, "supply_frames", lambda b, omega, load, flows, progress=None:
                        {q: ("frame", omega) for q in flows})
    monkeypatch.setattr(resources, "rotor", lambda m: "rotor")
    monkeypatch.setattr(resources, "bearing_load", lambda m, k: None)
    for i in range(100):
        speed = 50.0 + 0.37 * i
        resources.forward_model(machine, speed, (6, 20))
        resources.chain(machine, speed, (6, 20))
        resources.flooded_flow(machine, 0, speed)
        resources.frames(machine, 0, speed, [4e-6])
        resources.memo_put(("map", speed), i)
    for store in ("_TABLES", "_MODELS", "_CHAINS", "_VIEWS", "_THRESHOLDS", "_FRAMES", "_MEMO", "_KEY_LOCKS"):
        cache_ = getattr(resources, store)
        assert len(cache_) <= cache_.size <= 256, (store, len(cache_))
    assert len(resources._TABLES) <= 16 and len(resources._FRAMES) <= 16 and len(resources._MEMO) <= 16
    # the most recent speed is kept, the first long gone
    last = 50.0 + 0.37 * 99
    assert resources.memo_get(("map", last)) == 99 and resources.memo_get(("map", 50.0)) is None
