"""``python -m pyconnect.transport.router``: a usage line for --help, one-line errors, exit 1."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.errors import TransportError
from pyconnect.transport.router import main, start_router


def test_help_is_a_usage_not_an_endpoint(capsys: pytest.CaptureFixture[str]) -> None:
    # "--help" was taken as an endpoint: a two-exception traceback.
    with pytest.raises(SystemExit) as exited:
        main(["--help"])
    assert exited.value.code == 0
    assert capsys.readouterr().out.startswith("usage: python -m pyconnect.transport.router")


def test_a_bad_endpoint_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bogus"]) == 1
    error = capsys.readouterr().err
    assert error.startswith("router: zenoh router on bogus: ") and error.count("\n") == 1


def test_a_busy_port_is_one_line(locator: str, capsys: pytest.CaptureFixture[str]) -> None:
    first = start_router(listen=[locator])
    try:
        assert main([locator]) == 1
    finally:
        first.close()
    error = capsys.readouterr().err
    assert error.startswith(f"router: zenoh router on {locator}: ") and error.count("\n") == 1


def test_a_config_file_listens_where_it_says(tmp_path: Path, locator: str) -> None:
    # The command's default endpoint replaced the file's: a TLS listener became plain TCP on
    # every interface. Only endpoints given on the command line replace the file's.
    config = tmp_path / "router.json5"
    config.write_text(
        f'{{ mode: "router", listen: {{ endpoints: ["{locator}"] }}, '
        "scouting: { multicast: { enabled: false } } }",
        encoding="utf-8",
    )
    router = start_router(config=config)
    try:
        with pytest.raises(TransportError):  # the file's port is taken: by this router
            start_router(listen=[locator])
    finally:
        router.close()
