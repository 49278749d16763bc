"""Natural codecs against their anchors: image decode/encode, JointState and Twist vs dict codecs.

Run: ``.venv/bin/python -m bench.natural_codecs``. The cases of a table are timed in turns
(round-robin, 7 rounds) and each keeps its fastest round, so load from other processes hits
all of them alike; ratios are against the anchor row of the same table.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bench.timing import compare
from pyconnect.codecs import default_registry


def image_messages(height: int, width: int) -> tuple[Any, Any]:
    from rosbags.typesys import Stores, get_typestore
    from sensor_msgs.msg import Image

    pixels = np.random.default_rng(0).integers(0, 256, (height, width, 3), dtype=np.uint8)
    msg = Image(height=height, width=width, encoding="rgb8", step=width * 3)
    msg.data.frombytes(pixels.tobytes())
    types = get_typestore(Stores.ROS2_JAZZY).types
    rosbags_msg = types["sensor_msgs/msg/Image"](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=""
        ),
        height=height,
        width=width,
        encoding="rgb8",
        is_bigendian=0,
        step=width * 3,
        data=np.frombuffer(msg.data, np.uint8),
    )
    return msg, rosbags_msg


def bench_image_decode(height: int, width: int) -> None:
    from rosbags.image import message_to_cvimage

    decode = default_registry.lookup_message("sensor_msgs/msg/Image").decode
    msg, rosbags_msg = image_messages(height, width)
    compare(
        f"Image decode {width}x{height} rgb8",
        [
            ("rosbags-image message_to_cvimage", lambda: message_to_cvimage(rosbags_msg)),
            ("pyconnect ImageCodec.decode (rclpy message)", lambda: decode(msg)),
            ("pyconnect ImageCodec.decode (rosbags message)", lambda: decode(rosbags_msg)),
            ("np.array(msg.data) (one copy)", lambda: np.array(msg.data)),
        ],
    )


def bench_image_encode(height: int, width: int) -> None:
    from sensor_msgs.msg import Image

    encode = default_registry.lookup_message("sensor_msgs/msg/Image").encode
    pixels = np.random.default_rng(1).integers(0, 256, (height, width, 3), dtype=np.uint8)
    target = np.empty_like(pixels)

    def tobytes_setter() -> Any:
        msg = Image(height=height, width=width, encoding="bgr8", step=width * 3)
        msg.data = pixels.tobytes()
        return msg

    compare(
        f"Image encode {width}x{height} rgb8 ({pixels.nbytes / 1e6:.1f} MB)",
        [
            ("one memcpy into a fresh buffer: bytes(arr)", lambda: bytes(pixels)),
            ("one memcpy into a warm buffer: np.copyto", lambda: np.copyto(target, pixels)),
            ("pyconnect ImageCodec.encode", lambda: encode(pixels)),
            ("msg.data = arr.tobytes() (the usual way)", tobytes_setter),
        ],
        budget_s=0.15,
    )


def bench_image_fixed_cost() -> None:
    encode = default_registry.lookup_message("sensor_msgs/msg/Image").encode
    tiny = np.zeros((2, 2, 3), np.uint8)
    compare(
        "Image encode fixed cost (2x2 bgr8)",
        [
            ("bytes(arr)", lambda: bytes(tiny)),
            ("pyconnect ImageCodec.encode", lambda: encode(tiny)),
        ],
    )


def bench_against_dict_codec(msg: Any, label: str, value: Any) -> None:
    natural = default_registry.lookup_message(type(msg))
    as_dict = default_registry.lookup_dict(type(msg))
    plain = as_dict.to_dict(msg)
    compare(
        f"{label} decode",
        [
            ("generated dict codec to_dict", lambda: as_dict.to_dict(msg)),
            ("pyconnect natural decode", lambda: natural.decode(msg)),
        ],
    )
    compare(
        f"{label} encode",
        [
            ("generated dict codec from_dict", lambda: as_dict.from_dict(plain)),
            ("pyconnect natural encode", lambda: natural.encode(value)),
        ],
    )


def main() -> None:
    from geometry_msgs.msg import Twist, Vector3
    from sensor_msgs.msg import JointState

    bench_image_decode(480, 640)
    bench_image_decode(3000, 4096)
    bench_image_encode(1080, 1920)
    bench_image_encode(3000, 4096)
    bench_image_fixed_cost()
    joints = JointState(
        name=[f"joint_{i}" for i in range(12)],
        position=[0.1 * i for i in range(12)],
        velocity=[0.01 * i for i in range(12)],
        effort=[1.0 * i for i in range(12)],
    )
    bench_against_dict_codec(joints, "JointState (12 joints)", default_registry.decode(joints))
    twist = Twist(linear=Vector3(x=0.2, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.5))
    bench_against_dict_codec(twist, "Twist", ((0.2, 0.0, 0.0), (0.0, 0.0, 0.5)))


if __name__ == "__main__":
    main()
