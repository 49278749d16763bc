"""The `pyconnect.record` package: every public name resolves, and reading pulls in no writers."""

from __future__ import annotations

import subprocess
import sys

import pytest

from pyconnect import record


def test_every_public_name_resolves_to_its_home_module() -> None:
    assert sorted(record._HOMES) == sorted(record.__all__)
    for name in record.__all__:
        value = getattr(record, name)
        home = sys.modules[f"pyconnect.record.{record._HOMES[name]}"]
        assert value is getattr(home, name)
    assert set(record.__all__) <= set(dir(record))


def test_an_unknown_name_raises_attribute_error() -> None:
    with pytest.raises(AttributeError, match="has no attribute 'open_bags'"):
        _ = record.open_bags  # type: ignore[attr-defined]


def test_reading_a_bag_imports_no_recorder_logger_or_exporter() -> None:
    code = (
        "import sys\n"
        "from pyconnect.record import open_bag, bag_info\n"
        "print(sorted(m for m in sys.modules if m.startswith('pyconnect.record.')))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    loaded = done.stdout
    assert "pyconnect.record.bag_reader" in loaded
    for writer in ("mcap_recorder", "log_writer", "bag_export", "tables"):
        assert f"pyconnect.record.{writer}'" not in loaded


def test_the_names_the_readme_imports_from_the_package_are_there() -> None:
    # README: "align_table(...) gives the matches as one Arrow table", beside align.
    from pyconnect.record import align, align_table, open_bag

    assert align.__module__ == align_table.__module__ == "pyconnect.record.align"
    assert callable(open_bag)
