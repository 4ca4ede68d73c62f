"""A fuzz corpus of malformed model files: every one is refused with a ModelFileError that says what is wrong.

Each file under `tests/model/malformed/` is a complete model file (SPEC §2, §8) with one thing wrong. Its
leading comment lines `# expect: FRAGMENT` (at least one; the first line of the file) give what the message
must hold besides the file's path: the table and its index (`[[bearings]] 2`), the key, what was expected.
A bad file must never raise anything but ModelFileError (no KeyError, TypeError, tomllib errors, ...).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from lubeviz.errors import ModelFileError
from lubeviz.model.machine import MODELS_DIR
from lubeviz.model.files import load_machine

CORPUS = Path(__file__).with_name("malformed")
MALFORMED = sorted(CORPUS.glob("*.toml"))
VALID = sorted(MODELS_DIR.glob("*.toml"))
EXPECT = b"# expect:"


def expected_fragments(path: Path) -> list[str]:
    """The fragments of the file's leading `# expect:` lines (read as bytes: some files are not UTF-8 after them)."""
    fragments = []
    for line in path.read_bytes().splitlines():
        if not line.startswith(EXPECT):
            break
        fragments.append(line[len(EXPECT):].decode("utf-8").strip())
    return fragments


def test_the_corpus_holds_enough_files_each_with_an_expectation():
    assert len(MALFORMED) >= 45, f"{CORPUS} holds {len(MALFORMED)} model files; expected at least 45"
    for path in MALFORMED:
        assert path.read_bytes().startswith(EXPECT), f"{path.name}: the first line is not '# expect: FRAGMENT'"
        assert all(expected_fragments(path)), f"{path.name}: an empty '# expect:' fragment"


@pytest.mark.parametrize("path", MALFORMED, ids=[p.name for p in MALFORMED])
def test_a_malformed_model_file_is_refused_with_a_message_naming_what_is_wrong(path):
    with pytest.raises(ModelFileError) as refused:
        load_machine(path)
    message = str(refused.value)
    assert str(path) in message, f"the message does not name the file: {message}"
    for fragment in expected_fragments(path):
        assert fragment in message, f"expected {fragment!r} in the message: {message}"
    # The file and its table lead the message once (not re-wrapped: "F [[bearings]] 2: F [[bearings]] 2: ...").
    assert message.count(str(path)) == 1, f"the file is named more than once: {message}"


@pytest.mark.parametrize("path", VALID, ids=[p.name for p in VALID])
def test_every_shipped_model_file_loads(path):
    machine = load_machine(path)
    assert machine.source == str(path)
    assert machine.bearings and machine.n_nodes >= 2
