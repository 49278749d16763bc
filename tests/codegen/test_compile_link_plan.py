"""The libraries ``codecgen build --compile`` links for a package, planned without a compiler."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from pyconnect.codegen.compile_generate import GeneratedSources
from pyconnect.codegen.compile_link import plan_libraries


class _Toolchain:
    python_include = Path("/python/include")
    numpy_include = Path("/numpy/include")

    def include_dirs(self, packages: Iterable[str]) -> list[Path]:
        return [Path("/ros/include") / p for p in packages]

    def library_dirs(self) -> list[Path]:
        return [Path("/ros/lib")]


def test_each_stage_links_the_earlier_ones_own_libraries_first() -> None:
    stages = plan_libraries(
        sources=GeneratedSources(Path("/build"), "my_msgs", ()),
        dependencies=["std_msgs"],
        toolchain=_Toolchain(),  # type: ignore[arg-type]
        lib_dir=Path("/install/lib"),
        python_dir=Path("/install/python/my_msgs"),
        lib_rpath_from_python="../../lib",
    )
    names = [[library.output.name.split(".")[0] for library in stage] for stage in stages]
    assert names == [
        ["libmy_msgs__rosidl_generator_c"],
        ["libmy_msgs__rosidl_typesupport_fastrtps_c", "libmy_msgs__rosidl_typesupport_introspection_c"],
        ["libmy_msgs__rosidl_typesupport_c"],
        ["libmy_msgs__rosidl_generator_py"],
        ["my_msgs_s__rosidl_typesupport_c", "my_msgs_s__rosidl_typesupport_fastrtps_c",
         "my_msgs_s__rosidl_typesupport_introspection_c"],
    ]  # fmt: skip
    fastrtps = stages[1][0]
    assert fastrtps.cxx
    assert fastrtps.libraries == (
        "my_msgs__rosidl_generator_c", "std_msgs__rosidl_typesupport_fastrtps_c",
        "std_msgs__rosidl_generator_c", "rosidl_typesupport_fastrtps_c",
        "rosidl_typesupport_fastrtps_cpp", "rosidl_runtime_c", "fastcdr", "rcutils",
    )  # fmt: skip
    assert fastrtps.defines == ("ROSIDL_TYPESUPPORT_FASTRTPS_C_BUILDING_DLL_my_msgs",)
    assert fastrtps.rpath == ("$ORIGIN", "/ros/lib")
    assert fastrtps.soname == "libmy_msgs__rosidl_typesupport_fastrtps_c.so"
    extension = stages[4][1]
    assert extension.sources == (
        Path("/build/rosidl_generator_py/my_msgs/_my_msgs_s.ep.rosidl_typesupport_fastrtps_c.c"),
    )
    assert extension.rpath == ("$ORIGIN/../../lib", "/ros/lib")
    assert extension.soname is None
    assert extension.include_dirs[-2:] == (Path("/python/include"), Path("/numpy/include"))
