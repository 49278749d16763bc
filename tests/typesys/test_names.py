"""The field and constant names a compiled package cannot have (``compiled_name_problem``).

Each refused name was checked by compiling a one-message package that has it with rosidl: it
built a package that does not import, whose class pyconnect cannot use, or C that does not
compile. The names next to them that compile and work must stay allowed.
"""

from __future__ import annotations

import pytest

from pyconnect.typesys.names import compiled_name_problem


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("builtins", "the module the Python class rosidl generates takes its property decorator"),
        ("get_fields_and_field_types", "a method of the Python class rosidl generates"),
        ("SLOT_TYPES", "an attribute of the Python class rosidl generates"),
        ("linux", "a C macro on Linux"),
        ("unix", "a C macro on Linux"),
        ("errno", "a C macro on Linux"),
        ("complex", "a C macro on Linux"),
        ("constchar", "a C macro on Linux"),
        ("longdouble_t", "a C macro on Linux"),
        ("math_errhandling", "a C macro on Linux"),
        ("st_mtime", "a C macro on Linux"),
        ("int32_t", "a C type of rosidl's structs"),
        ("uint8_t", "a C type of rosidl's structs"),
    ],
)
def test_names_rosidl_builds_into_a_broken_package_are_refused(name: str, problem: str) -> None:
    found = compiled_name_problem(name)
    assert found is not None and found.startswith(problem), found


@pytest.mark.parametrize(
    "name",
    # Compiled and used without trouble: rosidl's methods see module names, not class ones;
    # these macros are function-like or defined as themselves; size_t is no struct member type.
    ["math", "numpy", "array", "property", "self", "value", "check_fields", "slot_types",
     "stdin", "stdout", "stderr", "npy_fseek", "sched_priority", "size_t", "float_t"],
)  # fmt: skip
def test_names_that_compile_and_work_pass(name: str) -> None:
    assert compiled_name_problem(name) is None
