"""Packages whose types refer to each other are refused by --from and --compile alike, exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codegen.cli import main
from pyconnect.codegen.package_order import build_order


def _cycle(root: Path) -> tuple[Path, Path]:
    """ca_msgs/Top -> cb_msgs/Mid -> ca_msgs/Leaf: two packages, each needing the other."""
    ca, cb = root / "ca_msgs", root / "cb_msgs"
    for folder, files in ((ca, {"Leaf": "int32 v\n", "Top": "cb_msgs/Mid m\n"}),
                          (cb, {"Mid": "ca_msgs/Leaf l\n"})):  # fmt: skip
        (folder / "msg").mkdir(parents=True)
        for name, text in files.items():
            (folder / "msg" / f"{name}.msg").write_text(text)
    return ca, cb


_REASONS = "ca_msgs/msg/Top uses cb_msgs/msg/Mid; cb_msgs/msg/Mid uses ca_msgs/msg/Leaf"
_ADVICE = "move the types they share into one package"


@pytest.mark.timeout(60)
def test_from_refuses_packages_that_need_each_other(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ca, cb = _cycle(tmp_path)
    out = tmp_path / "out"
    assert main(["build", "--from", str(ca), "--from", str(cb), "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        "codecgen: packages that need each other cannot be built: ca_msgs -> cb_msgs -> ca_msgs "
        f"({_REASONS}); {_ADVICE}\n"
    )
    assert not out.exists(), "nothing is written"


@pytest.mark.timeout(60)
def test_compile_refuses_them_with_the_same_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ca, cb = _cycle(tmp_path)
    prefix = tmp_path / "prefix"
    assert main(["build", "--compile", str(ca), "--compile", str(cb), "--prefix", str(prefix)]) == 2
    assert capsys.readouterr().err == (
        f"codecgen: {ca}: packages that need each other cannot be built: "
        f"ca_msgs -> cb_msgs -> ca_msgs ({_REASONS}); {_ADVICE}\n"
    )


def test_build_order_puts_dependencies_first_and_names_a_longer_cycle() -> None:
    def why(name: str, other: str) -> str:
        return f"{name} needs {other}"

    assert build_order({"c": {"b"}, "b": {"a", "x"}, "a": set()}, why=why) == ["a", "b", "c"]
    with pytest.raises(Exception) as caught:
        build_order({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}, why=why)
    assert str(caught.value) == (
        "packages that need each other cannot be built: a -> b -> c -> a "
        f"(a needs b; b needs c; c needs a); {_ADVICE}"
    )
