"""Rebuilding a dependency alone warns about the installed packages compiled against its old types.

Their C code holds the dependency's old structs: the next message using them aborts the process,
so the build names each such package with the command that rebuilds it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_install import InstallLayout


def _packages(root: Path) -> tuple[Path, Path]:
    base, top = root / "dep_base_msgs", root / "dep_top_msgs"
    (base / "msg").mkdir(parents=True)
    (top / "msg").mkdir(parents=True)
    (base / "msg" / "Part.msg").write_text("string name\n")
    (top / "package.xml").write_text(
        "<package format=\"3\"><name>dep_top_msgs</name><version>0.0.1</version>"
        "<depend>dep_base_msgs</depend></package>\n"
    )
    (top / "msg" / "Whole.msg").write_text("dep_base_msgs/Part p\ndep_base_msgs/Part[] ps\n")
    return base, top


@pytest.mark.timeout(600)
def test_a_changed_dependency_names_its_stale_dependents(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base, top = _packages(tmp_path)
    prefix = tmp_path / "prefix"
    compile_base = ["build", "--compile", str(base), "--prefix", str(prefix)]
    assert main([*compile_base, "--compile", str(top)]) == 0
    assert capsys.readouterr().err == ""
    # Rebuilt with the same types: nothing to say.
    assert main([*compile_base, "--force"]) == 0
    assert capsys.readouterr().err == ""
    (base / "msg" / "Part.msg").write_text("string name\nint32 added\n")
    assert main(compile_base) == 0
    layout = InstallLayout.for_prefix(prefix)
    root = layout.prefix
    assert capsys.readouterr().err == (
        f"codecgen: warning: dep_top_msgs in {root} was compiled against the previous types "
        "of dep_base_msgs, which changed: using it may abort the process; rebuild it: "
        f"codecgen build --compile {top.resolve()} --prefix {root}\n"
    )
    # The command it gives rebuilds the dependent (its stored digest covers the base's types).
    assert main(["build", "--compile", str(top.resolve()), "--prefix", str(root)]) == 0
    built = f"codecgen: dep_top_msgs: built ({layout.python / 'dep_top_msgs'})\n"
    assert capsys.readouterr() == (built, "")
