"""Natural codecs against their anchors: image decode/encode, JointState and Twist vs dict codecs.

Run: ``.venv/bin/python -m bench.natural_codecs`` (with pyconnect's glibc malloc settings, as
``pyconnect run`` applies them). The cases of a table are timed in turns
(round-robin, 7 rounds) and each keeps its fastest round, so load from other processes hits
all of them alike; ratios are against the anchor row of the same table.
"""

from __future__ import annotations

import os
import subprocess
import sys
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


def bench_point_cloud_encode(count: int) -> None:
    import array

    from pyconnect.codecs import wire

    dtype = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<f4")])
    points = np.zeros(count, dtype)
    rng = np.random.default_rng(2)
    for axis in ("x", "y", "z"):
        points[axis] = rng.random(count, np.float32)
    encode = default_registry.lookup_message("sensor_msgs/msg/PointCloud2").encode

    def copy_then_scan() -> Any:  # the usual way, for scale
        data = array.array("B")
        data.frombytes(points.data.cast("B"))
        return data, all(bool(np.isfinite(points[axis]).all()) for axis in ("x", "y", "z"))

    compare(
        f"PointCloud2 encode {count:,} points x,y,z,rgb ({points.nbytes / 1e6:.0f} MB)",
        [
            ("one memcpy into a fresh buffer: bytes(arr)", lambda: bytes(points)),
            ("pyconnect PointCloudCodec.encode (message)", lambda: encode(points)),
            (
                "pyconnect CDR encode (wire codec)",
                lambda: wire.encode(points, "sensor_msgs/msg/PointCloud2"),
            ),
            ("a copy, then isfinite per axis", copy_then_scan),
        ],
        budget_s=0.2,
    )


def bench_joint_state_decode(msg: Any) -> None:
    natural = default_registry.lookup_message(type(msg))

    def bare() -> Any:  # the same dicts from the same message, without any check
        return {
            n: {"position": p, "velocity": v, "effort": e}
            for n, p, v, e in zip(msg.name, msg.position, msg.velocity, msg.effort, strict=False)
        }

    assert bare() == natural.decode(msg)
    compare(
        f"JointState ({len(msg.name)} joints) natural decode",
        [
            ("bare comprehension building the same dicts", bare),
            ("pyconnect natural decode", lambda: natural.decode(msg)),
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

    from pyconnect.ros.large_messages import MALLOC_SETTINGS

    if not all(os.environ.get(name) == value for name, value in MALLOC_SETTINGS.items()):
        # Run under the settings from the start, as `pyconnect run` does: without them each
        # fresh multi-MB buffer is a page-fault storm (a 40 MB memcpy takes 26 ms, not 3),
        # which hides every other cost; mallopt() later cannot raise the threshold past 32 MiB.
        sys.stdout.flush()
        subprocess.run(
            [sys.executable, "-m", "bench.natural_codecs"],
            env={**os.environ, **MALLOC_SETTINGS},
            check=True,
        )
        return
    print("(run with the glibc malloc settings of `pyconnect run`)")

    bench_image_decode(480, 640)
    bench_image_decode(3000, 4096)
    bench_image_encode(1080, 1920)
    bench_image_encode(3000, 4096)
    bench_image_fixed_cost()
    bench_point_cloud_encode(2_500_000)
    joints = JointState(
        name=[f"joint_{i}" for i in range(12)],
        position=[0.1 * i for i in range(12)],
        velocity=[0.01 * i for i in range(12)],
        effort=[1.0 * i for i in range(12)],
    )
    bench_joint_state_decode(joints)
    bench_against_dict_codec(joints, "JointState (12 joints)", default_registry.decode(joints))
    twist = Twist(linear=Vector3(x=0.2, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.5))
    bench_against_dict_codec(twist, "Twist", ((0.2, 0.0, 0.0), (0.0, 0.0, 0.5)))


if __name__ == "__main__":
    main()
