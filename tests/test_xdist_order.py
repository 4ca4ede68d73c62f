"""The order in which `-n auto --dist loadfile` hands the files to its workers (`tests/conftest.py`): the files
that take minutes first, longest first, then the others by their number of tests, each file's tests together and
in their own order."""

from pathlib import Path
from types import SimpleNamespace

import pytest

from tests import conftest

ROOT = Path(__file__).resolve().parents[1]


def _items(*files_and_counts):
    return [SimpleNamespace(nodeid=f"{name}::test_{k}") for name, n in files_and_counts for k in range(n)]


def _worker(long_files, monkeypatch):
    monkeypatch.setattr(conftest, "LONG_FILES", long_files)
    return SimpleNamespace(workerinput={"workerid": "gw0"}, rootpath=ROOT, option=SimpleNamespace(dist="no"))


def test_long_files_go_first_longest_first_then_by_number_of_tests(monkeypatch):
    config = _worker({"tests/conftest.py": 50, "tests/__init__.py": 400}, monkeypatch)
    items = _items(("tests/a.py", 3), ("tests/conftest.py", 1), ("tests/b.py", 5), ("tests/__init__.py", 2),
                   ("tests/c.py", 3))
    conftest.pytest_collection_modifyitems(config, items)
    assert [i.nodeid for i in items] == [
        "tests/__init__.py::test_0", "tests/__init__.py::test_1", "tests/conftest.py::test_0",
        *(f"tests/b.py::test_{k}" for k in range(5)),
        *(f"tests/a.py::test_{k}" for k in range(3)), *(f"tests/c.py::test_{k}" for k in range(3))]


def test_a_long_file_that_is_gone_stops_the_run(monkeypatch):
    config = _worker({"tests/identify/test_no_such_file.py": 100}, monkeypatch)
    with pytest.raises(pytest.UsageError, match="test_no_such_file.py"):
        conftest.pytest_collection_modifyitems(config, _items(("tests/a.py", 1)))


def test_every_long_file_exists():
    assert all((ROOT / name).is_file() for name in conftest.LONG_FILES)


def test_the_controller_keeps_the_order_under_loadfile_and_a_single_process_run_is_left_alone():
    controller = SimpleNamespace(option=SimpleNamespace(dist="loadfile", loadscopereorder=True))
    conftest.pytest_configure(controller)
    assert controller.option.loadscopereorder is False
    single = SimpleNamespace(rootpath=ROOT, option=SimpleNamespace(dist="no"))
    items = _items(("tests/a.py", 1), ("tests/identify/test_orbit_fit.py", 1))
    conftest.pytest_collection_modifyitems(single, items)
    assert items[0].nodeid == "tests/a.py::test_0"
