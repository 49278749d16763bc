"""``python -m pyconnect.transport.router``: a usage line for --help, one-line errors, exit 1."""

from __future__ import annotations

import pytest

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
