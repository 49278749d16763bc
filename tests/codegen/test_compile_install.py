"""codecgen's installs replace and remove only what codecgen installed, never pip's packages."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_install import (
    InstallConflictError,
    InstallLayout,
    check_replaceable,
    installed_record,
)


def _distribution(
    layout: InstallLayout, package: str, installer: str | None, record: list[str] | None = None
) -> Path:
    """What an installer lays out in site-packages: the package and a dist-info listing it."""
    (layout.python / package).mkdir(parents=True)
    (layout.python / package / "__init__.py").write_text("VALUE = 42\n")
    (layout.python / package / "core.py").write_text("def important() -> int:\n    return 1\n")
    dist_info = layout.python / f"{package}-3.1.dist-info"
    dist_info.mkdir()
    (dist_info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\nVersion: 3.1\n")
    if installer is not None:
        (dist_info / "INSTALLER").write_text(f"{installer}\n")
    lines = record or [f"{package}/__init__.py,,", f"{package}/core.py,,"]
    lines += [f"{dist_info.name}/{name},," for name in ("METADATA", "INSTALLER", "RECORD")]
    (dist_info / "RECORD").write_text("\n".join(lines) + "\n")
    return dist_info


def _files(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()}


def test_uninstall_leaves_a_package_pip_installed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = InstallLayout.for_prefix(tmp_path / "prefix")
    _distribution(layout, "mylib", "pip")
    before = _files(layout.prefix)
    assert installed_record(layout, "mylib") == []
    assert main(["uninstall", "mylib", "--prefix", str(layout.prefix)]) == 1
    assert capsys.readouterr().err == (
        f"codecgen: mylib: no package built by codecgen in {layout.prefix}\n"
    )
    assert _files(layout.prefix) == before


def test_uninstall_leaves_files_a_record_lists_outside_the_prefix(tmp_path: Path) -> None:
    victim = tmp_path / "elsewhere" / "precious.txt"
    victim.parent.mkdir()
    victim.write_text("keep me\n")
    for entry in (str(victim), "../../../../elsewhere/precious.txt"):
        layout = InstallLayout.for_prefix(tmp_path / f"prefix{len(entry)}")
        _distribution(layout, "mylib", "codecgen", [f"{entry},,", "mylib/__init__.py,,"])
        assert main(["uninstall", "mylib", "--prefix", str(layout.prefix)]) == 1
        assert victim.is_file()
        assert (layout.python / "mylib" / "__init__.py").is_file()


def test_uninstall_removes_what_codecgen_installed(tmp_path: Path) -> None:
    layout = InstallLayout.for_prefix(tmp_path / "prefix")
    (layout.lib).mkdir(parents=True)
    (layout.lib / "libmylib__rosidl_generator_c.so").write_bytes(b"\0")
    record = [
        "mylib/__init__.py,,",
        "mylib/core.py,,",
        "../../../lib/libmylib__rosidl_generator_c.so,,",
    ]
    _distribution(layout, "mylib", "codecgen", record)
    assert main(["uninstall", "mylib", "--prefix", str(layout.prefix)]) == 0
    assert _files(layout.prefix) == set()


def test_an_install_does_not_replace_a_package_pip_installed(tmp_path: Path) -> None:
    layout = InstallLayout.for_prefix(tmp_path / "prefix")
    _distribution(layout, "mylib", "pip")
    with pytest.raises(InstallConflictError) as caught:
        check_replaceable(layout, "mylib")
    assert str(caught.value) == (
        f"mylib: {layout.prefix} already has the distribution mylib-3.1.dist-info "
        "(INSTALLER 'pip'), not a package built by codecgen: not replacing it (uninstall it "
        "first, or build into another --prefix)"
    )


def test_an_install_does_not_replace_a_package_of_a_distribution_named_otherwise(
    tmp_path: Path,
) -> None:
    # As the ROS wheels install std_msgs: the distribution is ros_std_msgs.
    layout = InstallLayout.for_prefix(tmp_path / "prefix")
    _distribution(layout, "std_msgs", None)
    (layout.python / "std_msgs-3.1.dist-info").rename(layout.python / "ros_std_msgs-3.1.dist-info")
    with pytest.raises(
        InstallConflictError, match=r"ros_std_msgs-3\.1\.dist-info \(no INSTALLER\)"
    ):
        check_replaceable(layout, "std_msgs")
    # A folder no distribution lists is not replaced either.
    (layout.python / "other_msgs").mkdir()
    with pytest.raises(InstallConflictError, match="which no installed distribution lists"):
        check_replaceable(layout, "other_msgs")


def test_the_active_environment_keeps_the_wheels_std_msgs() -> None:
    layout = InstallLayout.for_prefix(None)
    assert layout.prefix == Path(sys.prefix)
    with pytest.raises(InstallConflictError, match=r"std_msgs-[0-9.]+\.dist-info \(INSTALLER"):
        check_replaceable(layout, "std_msgs")


def test_codecgens_own_install_or_nothing_is_replaceable(tmp_path: Path) -> None:
    layout = InstallLayout.for_prefix(tmp_path / "prefix")
    check_replaceable(layout, "mylib")
    _distribution(layout, "mylib", "codecgen")
    check_replaceable(layout, "mylib")


def test_compile_refuses_to_replace_a_package_pip_installed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = InstallLayout.for_prefix(tmp_path / "prefix")
    _distribution(layout, "mylib", "pip")
    before = _files(layout.prefix)
    (tmp_path / "mylib" / "msg").mkdir(parents=True)
    (tmp_path / "mylib" / "msg" / "Thing.msg").write_text("int32 v\n")
    command = ["build", "--compile", str(tmp_path / "mylib"), "--prefix", str(layout.prefix)]
    assert main(command) == 2
    err = capsys.readouterr().err
    assert err.startswith("codecgen: mylib: ") and err.count("\n") == 1
    assert "mylib-3.1.dist-info (INSTALLER 'pip')" in err
    assert _files(layout.prefix) == before
