"""Generated dict codecs against hand-written straight-line code and a reflection walker.

Run: ``.venv/bin/python -m bench.dict_codecs``. For each type: msg -> dict and dict -> msg with
(1) hand-written code using the public message API (the anchor), (2) the generated codec,
(3) a walker of the rosidl_runtime_py kind that asks ``get_fields_and_field_types`` per call.
"""

from __future__ import annotations

from array import array
from collections.abc import Callable
from typing import Any

import numpy as np

from bench.timing import compare
from pyconnect.codecs import default_registry


# -- the reflection walker: rosidl_runtime_py's algorithm (message_to_ordereddict and
# set_message_fields), rewritten here because rosidl_runtime_py is not in the wheels.
def _slot_types(msg: Any) -> dict[str, Any]:
    return dict(zip(msg.get_fields_and_field_types().keys(), msg.SLOT_TYPES, strict=True))


def _convert_value(value: Any) -> Any:
    if isinstance(value, bytes | str | bool | int | float):
        return value
    if isinstance(value, array | np.ndarray):
        return value.tolist()
    if isinstance(value, list | tuple):
        return [_convert_value(v) for v in value]
    if hasattr(value, "get_fields_and_field_types"):
        return walk_to_dict(value)
    return value


def walk_to_dict(msg: Any) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for name in msg.get_fields_and_field_types():
        result[name] = _convert_value(getattr(msg, name))
    return result


def walk_from_dict(msg: Any, data: dict[str, Any]) -> Any:
    from rosidl_parser.definition import AbstractNestedType, NamespacedType

    for name, field_value in data.items():
        current = getattr(msg, name)
        field_type = type(current)
        if field_type is array:
            value: Any = field_type(current.typecode, field_value)
        elif field_type is np.ndarray:
            value = np.array(field_value, dtype=current.dtype)
        elif type(field_value) is field_type:
            value = field_value
        else:
            try:
                value = field_type(field_value)
            except TypeError:
                value = walk_from_dict(field_type(), field_value)
        slot_type = _slot_types(msg)[name]
        if isinstance(slot_type, AbstractNestedType) and isinstance(
            slot_type.value_type, NamespacedType
        ):
            element_class = _nested_class(slot_type.value_type)
            value = [walk_from_dict(element_class(), v) for v in value]
        setattr(msg, name, value)
    return msg


def _nested_class(namespaced: Any) -> Any:
    import importlib

    module = importlib.import_module(".".join(namespaced.namespaces))
    return getattr(module, namespaced.name)


# -- hand-written straight-line code, the way a careful user writes it --------------------------
def header_dict(h: Any) -> dict[str, Any]:
    return {"stamp": {"sec": h.stamp.sec, "nanosec": h.stamp.nanosec}, "frame_id": h.frame_id}


def set_header(h: Any, d: dict[str, Any]) -> None:
    h.stamp.sec = d["stamp"]["sec"]
    h.stamp.nanosec = d["stamp"]["nanosec"]
    h.frame_id = d["frame_id"]


def xyz(v: Any) -> dict[str, float]:
    return {"x": v.x, "y": v.y, "z": v.z}


def set_xyz(v: Any, d: dict[str, float]) -> None:
    v.x, v.y, v.z = d["x"], d["y"], d["z"]


def quat(q: Any) -> dict[str, float]:
    return {"x": q.x, "y": q.y, "z": q.z, "w": q.w}


def set_quat(q: Any, d: dict[str, float]) -> None:
    q.x, q.y, q.z, q.w = d["x"], d["y"], d["z"], d["w"]


def pose_dict(p: Any) -> dict[str, Any]:
    return {"position": xyz(p.position), "orientation": quat(p.orientation)}


def set_pose(p: Any, d: dict[str, Any]) -> None:
    set_xyz(p.position, d["position"])
    set_quat(p.orientation, d["orientation"])


def joint_state_cases() -> tuple[Any, Callable[[Any], Any], Callable[[dict[str, Any]], Any]]:
    from sensor_msgs.msg import JointState

    msg = JointState(name=[f"joint_{i}" for i in range(12)], position=[0.1 * i for i in range(12)],
                     velocity=[0.0] * 12, effort=[1.0] * 12)  # fmt: skip

    def to_dict(m: Any) -> dict[str, Any]:
        return {"header": header_dict(m.header), "name": list(m.name),
                "position": m.position.tolist(), "velocity": m.velocity.tolist(),
                "effort": m.effort.tolist()}  # fmt: skip

    def from_dict(d: dict[str, Any]) -> Any:
        m = JointState()
        set_header(m.header, d["header"])
        m.name, m.position, m.velocity, m.effort = (
            d["name"],
            d["position"],
            d["velocity"],
            d["effort"],
        )
        return m

    return msg, to_dict, from_dict


def twist_cases() -> tuple[Any, Callable[[Any], Any], Callable[[dict[str, Any]], Any]]:
    from geometry_msgs.msg import Twist

    msg = Twist()
    msg.linear.x, msg.angular.z = 0.5, 0.1

    def to_dict(m: Any) -> dict[str, Any]:
        return {"linear": xyz(m.linear), "angular": xyz(m.angular)}

    def from_dict(d: dict[str, Any]) -> Any:
        m = Twist()
        set_xyz(m.linear, d["linear"])
        set_xyz(m.angular, d["angular"])
        return m

    return msg, to_dict, from_dict


def imu_cases() -> tuple[Any, Callable[[Any], Any], Callable[[dict[str, Any]], Any]]:
    from sensor_msgs.msg import Imu

    msg = Imu()
    msg.linear_acceleration.z = 9.81

    def to_dict(m: Any) -> dict[str, Any]:
        return {"header": header_dict(m.header), "orientation": quat(m.orientation),
                "orientation_covariance": m.orientation_covariance.tolist(),
                "angular_velocity": xyz(m.angular_velocity),
                "angular_velocity_covariance": m.angular_velocity_covariance.tolist(),
                "linear_acceleration": xyz(m.linear_acceleration),
                "linear_acceleration_covariance": m.linear_acceleration_covariance.tolist()}  # fmt: skip

    def from_dict(d: dict[str, Any]) -> Any:
        m = Imu()
        set_header(m.header, d["header"])
        set_quat(m.orientation, d["orientation"])
        m.orientation_covariance = d["orientation_covariance"]
        set_xyz(m.angular_velocity, d["angular_velocity"])
        m.angular_velocity_covariance = d["angular_velocity_covariance"]
        set_xyz(m.linear_acceleration, d["linear_acceleration"])
        m.linear_acceleration_covariance = d["linear_acceleration_covariance"]
        return m

    return msg, to_dict, from_dict


def pose_stamped_cases() -> tuple[Any, Callable[[Any], Any], Callable[[dict[str, Any]], Any]]:
    from geometry_msgs.msg import PoseStamped

    msg = PoseStamped()
    msg.pose.position.x = 1.0

    def to_dict(m: Any) -> dict[str, Any]:
        return {"header": header_dict(m.header), "pose": pose_dict(m.pose)}

    def from_dict(d: dict[str, Any]) -> Any:
        m = PoseStamped()
        set_header(m.header, d["header"])
        set_pose(m.pose, d["pose"])
        return m

    return msg, to_dict, from_dict


def point_cloud_cases() -> tuple[Any, Callable[[Any], Any], Callable[[dict[str, Any]], Any]]:
    from sensor_msgs.msg import PointCloud2, PointField

    fields = [PointField(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyz")]
    msg = PointCloud2(height=1, width=0, fields=fields, point_step=12, row_step=0, is_dense=True)

    def to_dict(m: Any) -> dict[str, Any]:
        return {"header": header_dict(m.header), "height": m.height, "width": m.width,
                "fields": [{"name": f.name, "offset": f.offset, "datatype": f.datatype,
                            "count": f.count} for f in m.fields],
                "is_bigendian": m.is_bigendian, "point_step": m.point_step,
                "row_step": m.row_step, "data": m.data.tobytes(), "is_dense": m.is_dense}  # fmt: skip

    def from_dict(d: dict[str, Any]) -> Any:
        m = PointCloud2()
        set_header(m.header, d["header"])
        m.height, m.width = d["height"], d["width"]
        m.fields = [PointField(name=f["name"], offset=f["offset"], datatype=f["datatype"],
                               count=f["count"]) for f in d["fields"]]  # fmt: skip
        m.is_bigendian, m.point_step, m.row_step = d["is_bigendian"], d["point_step"], d["row_step"]
        m.data.frombytes(d["data"])
        m.is_dense = d["is_dense"]
        return m

    return msg, to_dict, from_dict


def path_cases() -> tuple[Any, Callable[[Any], Any], Callable[[dict[str, Any]], Any]]:
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Path

    msg = Path(poses=[PoseStamped() for _ in range(100)])

    def to_dict(m: Any) -> dict[str, Any]:
        return {"header": header_dict(m.header),
                "poses": [{"header": header_dict(p.header), "pose": pose_dict(p.pose)}
                          for p in m.poses]}  # fmt: skip

    def from_dict(d: dict[str, Any]) -> Any:
        m = Path()
        set_header(m.header, d["header"])
        poses = []
        for pd in d["poses"]:
            p = PoseStamped()
            set_header(p.header, pd["header"])
            set_pose(p.pose, pd["pose"])
            poses.append(p)
        m.poses = poses
        return m

    return msg, to_dict, from_dict


CASES = {
    "JointState (12 joints)": joint_state_cases,
    "Twist": twist_cases,
    "Imu": imu_cases,
    "PoseStamped": pose_stamped_cases,
    "PointCloud2 (metadata)": point_cloud_cases,
    "nav_msgs/Path (100 poses)": path_cases,
}


def bench_type(title: str, make: Callable[[], tuple[Any, Any, Any]]) -> tuple[float, ...]:
    """Time one type both ways; returns the four ratios of the summary table."""
    msg, hand_to, hand_from = make()
    codec = default_registry.lookup_dict(type(msg))
    data = codec.to_dict(msg)
    assert hand_to(msg) == data and codec.from_dict(data) == msg == hand_from(data)
    assert walk_from_dict(type(msg)(), walk_to_dict(msg)) == msg
    to_t = compare(f"{title}: msg -> dict", [
        ("hand-written straight-line (public API)", lambda: hand_to(msg)),
        ("generated to_dict", lambda: codec.to_dict(msg)),
        ("reflection walker (get_fields_and_field_types)", lambda: walk_to_dict(msg)),
    ])  # fmt: skip
    from_t = compare(f"{title}: dict -> msg", [
        ("hand-written straight-line (public API)", lambda: hand_from(data)),
        ("generated from_dict (checked)", lambda: codec.from_dict(data)),
        ("reflection walker (setattr per field)", lambda: walk_from_dict(type(msg)(), data)),
    ])  # fmt: skip
    hand, generated, walker = to_t.values()
    hand_f, generated_f, walker_f = from_t.values()
    return generated / hand, walker / generated, generated_f / hand_f, walker_f / generated_f


def main() -> None:
    rows = [(title, bench_type(title, make)) for title, make in CASES.items()]
    print("\nSummary: generated <= 1.1x hand-written; reflection walker >= 7x generated")
    print(f"  {'type':<27} {'gen/hand':>9} {'walker/gen':>11} {'gen/hand':>9} {'walker/gen':>11}")
    print(f"  {'':<27} {'msg -> dict':>21} {'dict -> msg':>21}")
    for title, (to_hand, to_walker, from_hand, from_walker) in rows:
        print(
            f"  {title:<27} {to_hand:>8.2f}x {to_walker:>10.1f}x {from_hand:>8.2f}x {from_walker:>10.1f}x"
        )


if __name__ == "__main__":
    main()
