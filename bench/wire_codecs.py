"""CDR wire codecs against rosbags and rclpy, side by side in one run: ``python -m bench.wire_codecs``.

Targets (issue 6): a 1080p rgb8 Image decodes from a memoryview in <= 5 us (rosbags'
``deserialize_cdr`` is the reference, rclpy's ``deserialize_message`` the slow anchor); encoding
it costs <= 1.2x one memcpy of the pixels; a JointState (12 joints) decodes in no more than
rclpy's ``deserialize_message`` plus the generated dict codec.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bench.timing import compare


def _image_cases() -> None:
    from rclpy.serialization import deserialize_message, serialize_message
    from rosbags.typesys import Stores, get_typestore
    from sensor_msgs.msg import Image

    from pyconnect.codecs import wire

    typestore = get_typestore(Stores.ROS2_JAZZY)
    pixels = np.random.default_rng(1).integers(0, 255, (1080, 1920, 3), dtype=np.uint8)
    msg = Image(height=1080, width=1920, encoding="rgb8", step=1920 * 3)
    msg.header.frame_id = "camera"
    msg.data.frombytes(pixels.tobytes())
    cdr = serialize_message(msg)
    view = memoryview(cdr)
    codec = wire.wire_codec("sensor_msgs/msg/Image")
    assert (wire.decode(view, "sensor_msgs/msg/Image") == pixels).all()

    compare(
        "1080p rgb8 Image decode from a memoryview (6.2 MB)",
        [
            ("rosbags typestore.deserialize_cdr", lambda: typestore.deserialize_cdr(view, "sensor_msgs/msg/Image")),
            ("wire.to_dict (lossless dict, data copied to bytes)", lambda: codec.to_dict(view)),
            ("wire codec.decode_view", lambda: codec.decode_view(view)),
            ("wire.decode -> ndarray (natural, registry lookup)", lambda: wire.decode(view, "sensor_msgs/msg/Image")),
            ("rclpy deserialize_message", lambda: deserialize_message(cdr, Image)),
        ],
    )  # fmt: skip

    fields = codec.to_dict(view)
    rosbags_msg = typestore.deserialize_cdr(view, "sensor_msgs/msg/Image")

    def rclpy_serialize() -> Any:
        fresh = Image(height=1080, width=1920, encoding="rgb8", step=1920 * 3)
        fresh.data.frombytes(pixels)
        return serialize_message(fresh)

    compare(
        "1080p rgb8 Image encode to CDR bytes",
        [
            ("one memcpy of the pixels (ndarray.tobytes)", pixels.tobytes),
            ("wire.encode(ndarray) (natural)", lambda: wire.encode(pixels, "sensor_msgs/msg/Image")),
            ("wire codec.from_dict(dict)", lambda: codec.from_dict(fields)),
            ("rosbags typestore.serialize_cdr", lambda: typestore.serialize_cdr(rosbags_msg, "sensor_msgs/msg/Image")),
            ("rclpy Image + data.frombytes + serialize_message", rclpy_serialize),
        ],
    )  # fmt: skip


def _joint_state_cases() -> None:
    from rclpy.serialization import deserialize_message, serialize_message
    from rosbags.typesys import Stores, get_typestore
    from sensor_msgs.msg import JointState

    from pyconnect import codecs
    from pyconnect.codecs import wire

    typestore = get_typestore(Stores.ROS2_JAZZY)
    names = [f"joint_{i}" for i in range(12)]
    msg = JointState(name=names, position=[0.1 * i for i in range(12)],
                     velocity=[0.2 * i for i in range(12)], effort=[0.3 * i for i in range(12)])  # fmt: skip
    msg.header.frame_id = "base"
    cdr = serialize_message(msg)
    view = memoryview(cdr)
    dict_codec = codecs.default_registry.lookup_dict(JointState)
    codec = wire.wire_codec("sensor_msgs/msg/JointState")
    natural = codecs.lookup(JointState)
    fields = dict_codec.to_dict(msg)

    compare(
        "JointState (12 joints) decode",
        [
            ("rclpy deserialize_message + generated to_dict", lambda: dict_codec.to_dict(deserialize_message(cdr, JointState))),
            ("rclpy deserialize_message + natural decode", lambda: natural.decode(deserialize_message(cdr, JointState))),
            ("wire codec.to_dict", lambda: codec.to_dict(view)),
            ("wire.decode (natural, dict by joint name)", lambda: wire.decode(view, "sensor_msgs/msg/JointState")),
            ("rosbags typestore.deserialize_cdr", lambda: typestore.deserialize_cdr(view, "sensor_msgs/msg/JointState")),
        ],
    )  # fmt: skip
    compare(
        "JointState (12 joints) encode",
        [
            ("rclpy generated from_dict + serialize_message", lambda: serialize_message(dict_codec.from_dict(fields))),
            ("wire codec.from_dict", lambda: codec.from_dict(fields)),
        ],
    )  # fmt: skip


def _small_cases() -> None:
    from geometry_msgs.msg import PoseStamped, Twist
    from rclpy.serialization import deserialize_message, serialize_message
    from rosbags.typesys import Stores, get_typestore
    from sensor_msgs.msg import Imu

    from pyconnect import codecs
    from pyconnect.codecs import wire

    typestore = get_typestore(Stores.ROS2_JAZZY)
    for cls in (Twist, PoseStamped, Imu):
        full_name = codecs.default_registry.resolve(cls)
        cdr = serialize_message(cls())
        view = memoryview(cdr)
        dict_codec = codecs.default_registry.lookup_dict(cls)
        codec = wire.wire_codec(full_name)

        def rclpy_path(cdr: bytes = cdr, cls: type = cls, dict_codec: Any = dict_codec) -> Any:
            return dict_codec.to_dict(deserialize_message(cdr, cls))

        compare(
            f"{full_name} decode to a dict",
            [
                ("rclpy deserialize_message + generated to_dict", rclpy_path),
                ("wire codec.to_dict", lambda codec=codec, view=view: codec.to_dict(view)),
                ("rosbags typestore.deserialize_cdr",
                 lambda view=view, name=full_name: typestore.deserialize_cdr(view, name)),
            ],
        )  # fmt: skip


def main() -> None:
    _image_cases()
    _joint_state_cases()
    _small_cases()


if __name__ == "__main__":
    main()
