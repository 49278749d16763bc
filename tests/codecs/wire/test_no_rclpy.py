"""``pyconnect.codecs.wire`` works with rclpy and every ROS message package hidden."""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    import importlib.abc, sys

    HIDDEN = ("rclpy", "rosidl_runtime_py", "std_msgs", "sensor_msgs", "geometry_msgs",
              "builtin_interfaces", "test_msgs", "nav_msgs", "rpyutils")

    class Hide(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in HIDDEN:
                raise ImportError(f"hidden for this test: {name}")
            return None

    sys.meta_path.insert(0, Hide())
    import numpy as np
    from pyconnect.codecs import wire

    image = np.arange(24, dtype=np.uint8).reshape(2, 4, 3)
    cdr = wire.encode(image, "sensor_msgs/msg/Image")
    back = wire.decode(cdr, "sensor_msgs/msg/Image")
    assert isinstance(back, np.ndarray) and (back == image).all(), back
    assert wire.to_dict(cdr, "sensor_msgs/Image")["encoding"] == "bgr8"
    joints = wire.from_dict({"name": ["a"], "position": [1.5]}, "sensor_msgs/msg/JointState")
    assert wire.to_dict(joints, "sensor_msgs/msg/JointState")["position"] == [1.5]
    strings = wire.from_dict({"string_value": "x"}, "test_msgs/msg/Strings")
    assert wire.to_dict(strings, "test_msgs/msg/Strings")["string_value"] == "x"
    # A user codec without to_fields writes through its message: without the class, it says so.
    from pyconnect.codecs import Registry
    from pyconnect.errors import EncodeError

    class Plain:
        msg_type = "std_msgs/msg/String"
        lossless = True
        def encode(self, value): raise AssertionError("no message class to build")
        def decode(self, msg): return msg.data

    registry = Registry()
    registry.register("std_msgs/msg/String", Plain())
    assert wire.decode(wire.from_dict({"data": "y"}, "std_msgs/msg/String"),
                       "std_msgs/msg/String", registry=registry) == "y"
    try:
        wire.encode("x", "std_msgs/msg/String", registry=registry)
    except EncodeError as error:
        assert str(error).startswith(
            "std_msgs/msg/String: codec Plain has no to_fields(value), and the message its "
            "encode builds cannot be read without the type's class"), error
    else:
        raise AssertionError("no EncodeError")
    leaked = sorted(m for m in sys.modules if m.split(".")[0] in HIDDEN)
    assert not leaked, leaked
    print("ok")
    """
)


def test_wire_codecs_need_no_rclpy_and_no_message_classes() -> None:
    result = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok"
